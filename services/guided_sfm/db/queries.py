"""Small query functions taking a Session; the API's dependencies and the actions share them."""

from __future__ import annotations

from sqlalchemy import func, select
from sqlalchemy.orm import Session

from guided_sfm.db.models import (
    ACTIVE_STATES,
    ROLES,
    EditSetRow,
    Image,
    Job,
    Membership,
    Project,
    User,
    Version,
)


def user_by_name(session: Session, username: str) -> User | None:
    return session.scalar(select(User).where(User.username == username))


def role_of(session: Session, project_id: int, user_id: int) -> str | None:
    return session.scalar(
        select(Membership.role).where(Membership.project_id == project_id, Membership.user_id == user_id)
    )


def owner_name(session: Session, project_id: int) -> str | None:
    """The username of the project's first owner (the creator unless ownership was handed on)."""
    return session.scalar(
        select(User.username).join(Membership, Membership.user_id == User.id)
        .where(Membership.project_id == project_id, Membership.role == "owner").order_by(Membership.user_id)
        .limit(1)
    )


def role_at_least(role: str | None, needed: str) -> bool:
    return role is not None and ROLES.index(role) >= ROLES.index(needed)


def projects_of(session: Session, user_id: int) -> list[Project]:
    query = (
        select(Project).join(Membership, Membership.project_id == Project.id)
        .where(Membership.user_id == user_id).order_by(Project.id)
    )
    return list(session.scalars(query))


def members(session: Session, project_id: int) -> list[Membership]:
    query = select(Membership).where(Membership.project_id == project_id).order_by(Membership.user_id)
    return list(session.scalars(query))


def owner_count(session: Session, project_id: int) -> int:
    query = select(func.count()).where(Membership.project_id == project_id, Membership.role == "owner")
    return session.scalar(query) or 0


def images(session: Session, project_id: int) -> list[Image]:
    query = select(Image).where(Image.project_id == project_id).order_by(Image.seq, Image.id)
    return list(session.scalars(query))


def image_ids_by_name(session: Session, project_id: int) -> dict[str, int]:
    rows = session.execute(select(Image.name, Image.id).where(Image.project_id == project_id))
    return {name: image_id for name, image_id in rows}


def versions(session: Session, project_id: int) -> list[Version]:
    return list(session.scalars(select(Version).where(Version.project_id == project_id).order_by(Version.id)))


def applied_revisions(session: Session, project_id: int) -> dict[tuple[int, int], int]:
    """(edit set id, revision) -> the version its succeeded apply job made."""
    jobs = session.scalars(select(Job).where(Job.project_id == project_id, Job.kind == "apply",
                                             Job.state == "succeeded", Job.version_id.is_not(None)))
    return {(job.params.get("edit_set_id"), job.params.get("revision")): job.version_id for job in jobs}


def edit_sets(session: Session, project_id: int) -> list[EditSetRow]:
    query = select(EditSetRow).where(EditSetRow.project_id == project_id).order_by(EditSetRow.id)
    return list(session.scalars(query))


def active_job(session: Session, project_id: int) -> Job | None:
    query = select(Job).where(Job.project_id == project_id, Job.state.in_(ACTIVE_STATES))
    return session.scalar(query)


def jobs(session: Session, project_id: int) -> list[Job]:
    return list(session.scalars(select(Job).where(Job.project_id == project_id).order_by(Job.id.desc())))


def is_empty(session: Session, project_id: int) -> bool:
    has_image = session.scalar(select(Image.id).where(Image.project_id == project_id).limit(1))
    has_version = session.scalar(select(Version.id).where(Version.project_id == project_id).limit(1))
    return has_image is None and has_version is None
