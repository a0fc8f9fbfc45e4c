"""Notifications: mentions, review requests, reviews and finished jobs, each for one user."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from sqlalchemy import select, update
from sqlalchemy.orm import Session

from guided_sfm.db.models import NOTIFICATION_KINDS, Notification

MAX_LIST = 200


def notify(session: Session, user_ids: Iterable[int], project_id: int, kind: str, target: dict[str, Any],
           text: str) -> None:
    """One unread notification per user (added to the caller's transaction)."""
    if kind not in NOTIFICATION_KINDS:
        raise ValueError(f"unknown notification kind {kind!r}")
    for user_id in sorted(set(user_ids)):
        session.add(Notification(user_id=user_id, project_id=project_id, kind=kind, target=target,
                                 text=text[:500], read=False))
    session.flush()


def of_user(session: Session, user_id: int, unread: bool, projects: list[int] | None,
            limit: int = MAX_LIST) -> list[Notification]:
    """The user's notifications, newest first; `projects` limits them (an access token's projects)."""
    query = select(Notification).where(Notification.user_id == user_id)
    if unread:
        query = query.where(Notification.read.is_(False))
    if projects is not None:
        query = query.where(Notification.project_id.in_(projects))
    return list(session.scalars(query.order_by(Notification.id.desc()).limit(limit)))


def mark_read(session: Session, user_id: int, ids: list[int], projects: list[int] | None) -> int:
    """Mark the user's own notifications read; others' ids are skipped (as if absent)."""
    query = update(Notification).where(Notification.user_id == user_id, Notification.id.in_(ids))
    if projects is not None:
        query = query.where(Notification.project_id.in_(projects))
    count = session.execute(query.values(read=True)).rowcount
    session.commit()
    return count
