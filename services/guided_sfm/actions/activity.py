"""The activity log (append-only: rows are added, never changed) and the end of a job in it."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session

from guided_sfm.actions import notifications
from guided_sfm.core.errors import InvalidInput
from guided_sfm.db.models import ACTIVITY_ACTIONS, Activity, Job, User

MAX_PAGE = 200


@dataclass(frozen=True)
class Actor:
    """Who makes a change: the user, and the personal access token's name when one was used."""

    user_id: int | None
    username: str | None
    token: str | None = None

    @classmethod
    def of(cls, user: User | None, token: str | None = None) -> Actor:
        return cls(user.id, user.username, token) if user is not None else cls(None, None, token)


def record(session: Session, project_id: int, actor: Actor, action: str, target: dict[str, Any] | None = None,
           detail: dict[str, Any] | None = None, *, commit: bool = True) -> Activity:
    """Append an entry (committed unless the caller commits it with the change it describes)."""
    if action not in ACTIVITY_ACTIONS:
        raise ValueError(f"unknown activity action {action!r}")
    entry = Activity(project_id=project_id, user_id=actor.user_id, username=actor.username,
                     token_name=actor.token, action=action, target=target or {"kind": "project"},
                     detail=detail or {})
    session.add(entry)
    if commit:
        session.commit()
    else:
        session.flush()
    return entry


def page(session: Session, project_id: int, limit: int, before: int | None = None,
         username: str | None = None, action: str | None = None) -> tuple[list[Activity], int | None]:
    """Newest first, ids below `before`; returns the entries and the `before` of the next page
    (None after the last). Paging by id, not offset, so new entries never shift a page."""
    if action is not None and action not in ACTIVITY_ACTIONS:
        raise InvalidInput(f"unknown action {action!r}; one of {', '.join(ACTIVITY_ACTIONS)}")
    query = select(Activity).where(Activity.project_id == project_id)
    if before is not None:
        query = query.where(Activity.id < before)
    if username is not None:
        query = query.where(Activity.username == username)
    if action is not None:
        query = query.where(Activity.action == action)
    rows = list(session.scalars(query.order_by(Activity.id.desc()).limit(limit + 1)))
    more = len(rows) > limit
    return rows[:limit], (rows[limit - 1].id if more else None)


def job_started_by(session: Session, job: Job) -> Actor:
    """Who queued the job, with the token they used (from the entry that queued it)."""
    entry = session.scalar(select(Activity).where(
        Activity.project_id == job.project_id, Activity.action.in_(("reconstruct", "import", "apply")),
        Activity.detail["job_id"].as_integer() == job.id))
    user = session.get(User, job.created_by) if job.created_by is not None else None
    return Actor.of(user, entry.token_name if entry is not None else None)


def job_ended(session: Session, job_id: int) -> None:
    """Log a job's end (`job_end`, with its state and version) and tell whoever queued it."""
    job = session.get(Job, job_id)
    if job is None or job.state not in ("succeeded", "failed", "cancelled"):
        return
    actor = job_started_by(session, job)
    target = {"kind": "version", "id": job.version_id} if job.version_id else {"kind": "job", "id": job.id}
    detail = {"state": job.state, "job_id": job.id, "kind": job.kind, "version_id": job.version_id}
    record(session, job.project_id, actor, "job_end", target, detail, commit=False)
    if job.created_by is not None:
        text = f"your {job.kind} job {job.id} {job.state}" + (
            f": version {job.version_id}" if job.version_id else f": {job.error or job.message}")
        notifications.notify(session, [job.created_by], job.project_id, "job_finished",
                             {"kind": "job", "id": job.id, "version_id": job.version_id}, text)
    session.commit()
