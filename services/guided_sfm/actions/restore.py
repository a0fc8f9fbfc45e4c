"""Restore: a new head version with an old version's content (hard links or a manifest naming the
same objects; nothing copied)."""

from __future__ import annotations

from sqlalchemy.orm import Session

from guided_sfm.actions import webhooks
from guided_sfm.db import queries
from guided_sfm.db.models import Project, Version
from guided_sfm.errors import Conflict
from guided_sfm.storage import Store


def restore(session: Session, store: Store, project: Project, version: Version,
            user_id: int) -> Version:
    if queries.active_job(session, project.id) is not None:
        raise Conflict(f"project {project.id} has a queued or running job; restore when it ends")
    relative = store.copy_version(project.id, version.path)
    try:
        restored = Version(project_id=project.id, parent_id=project.head_version_id, kind="restore",
                           author_id=user_id, message=f"restored version {version.id}",
                           stats=dict(version.stats), path=relative, edits=None)
        session.add(restored)
        session.flush()
        project.head_version_id = restored.id
        webhooks.version_created(session, restored, is_head=True)
        session.commit()
    except BaseException:
        session.rollback()
        store.discard(relative)
        raise
    return restored
