"""Projects: made with their creator as owner; deleted with their rows and files, never while a job runs."""

from __future__ import annotations

from sqlalchemy.orm import Session

from guided_sfm.db import queries
from guided_sfm.db.models import Membership, Project
from guided_sfm.errors import Conflict
from guided_sfm.storage import Store, project_prefix


def add(session: Session, user_id: int, name: str, description: str = "") -> Project:
    """A new project owned by the user, flushed (the caller commits it with what else it adds)."""
    project = Project(name=name, description=description, created_by=user_id)
    session.add(project)
    session.flush()
    session.add(Membership(project_id=project.id, user_id=user_id, role="owner"))
    session.flush()
    return project


def create(session: Session, store: Store, user_id: int, name: str, description: str = "") -> Project:
    project = add(session, user_id, name, description)
    # SQLite reuses the id of a deleted last row: files a crashed deletion left are not this project's
    store.delete_project(project.id)
    session.commit()
    return project


def delete(session: Session, store: Store, project: Project) -> None:
    """Rows first (one transaction), then the files; 409 while a job is queued or running."""
    if queries.active_job(session, project.id) is not None:
        raise Conflict(f"project {project.id} has a queued or running job; cancel it first")
    project_id = project.id
    project.head_version_id = None  # the head points into the versions being deleted
    session.flush()
    session.delete(project)
    session.commit()
    store.remove_committed([project_prefix(project_id)])
