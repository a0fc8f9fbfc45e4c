"""Project members and their roles: add, change, remove; the last owner always stays."""

from __future__ import annotations

from sqlalchemy.orm import Session

from guided_sfm.db import queries
from guided_sfm.db.models import Membership, Project
from guided_sfm.errors import Conflict, NotFound


def set_role(session: Session, project: Project, username: str, role: str) -> Membership:
    """Add the user with this role, or change their role."""
    user_id = _user_id(session, username)
    membership = session.get(Membership, (project.id, user_id))
    if role != "owner":
        _keep_an_owner(session, project, membership)
    if membership is None:
        membership = Membership(project_id=project.id, user_id=user_id, role=role)
        session.add(membership)
    membership.role = role
    session.commit()
    return membership


def remove(session: Session, project: Project, username: str) -> None:
    membership = session.get(Membership, (project.id, _user_id(session, username)))
    if membership is None:
        raise NotFound(f"{username!r} is not a member of project {project.id}")
    _keep_an_owner(session, project, membership)
    session.delete(membership)
    session.commit()


def _user_id(session: Session, username: str) -> int:
    user = queries.user_by_name(session, username)
    if user is None:
        raise NotFound(f"no user named {username!r}")
    return user.id


def _keep_an_owner(session: Session, project: Project, membership: Membership | None) -> None:
    last_owner = membership is not None and membership.role == "owner"
    if last_owner and queries.owner_count(session, project.id) == 1:
        raise Conflict(f"{membership.user.username!r} is the last owner of project {project.id}")
