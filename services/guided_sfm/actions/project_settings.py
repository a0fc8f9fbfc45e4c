"""A project's settings (name, description, require_approval) and its published version."""

from __future__ import annotations

from typing import Any

from sqlalchemy.orm import Session

from guided_sfm.actions.activity import Actor, record
from guided_sfm.db.models import Project, Version

SETTINGS = ("name", "description", "require_approval")


def change(session: Session, project: Project, changes: dict[str, Any], actor: Actor) -> Project:
    """Apply the given settings (those left out keep their value) and log what changed."""
    changed = {key: value for key, value in changes.items()
               if key in SETTINGS and value is not None and getattr(project, key) != value}
    for key, value in changed.items():
        setattr(project, key, value)
    if changed:
        record(session, project.id, actor, "settings", {"kind": "project"}, changed, commit=False)
    session.commit()
    return project


def publish(session: Session, project: Project, version: Version, actor: Actor) -> Project:
    """Mark the version as the team's accepted result (the deliverable the project list shows)."""
    project.published_version_id = version.id
    record(session, project.id, actor, "publish", {"kind": "version", "id": version.id}, {},
           commit=False)
    session.commit()
    return project
