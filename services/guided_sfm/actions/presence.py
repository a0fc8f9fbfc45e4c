"""Presence: each member's last report (where they are: an edit set, a version), kept 30 s."""

from __future__ import annotations

from datetime import timedelta

from sqlalchemy import select
from sqlalchemy.dialects.postgresql import insert as pg_insert
from sqlalchemy.dialects.sqlite import insert as sqlite_insert
from sqlalchemy.orm import Session, sessionmaker

from guided_sfm.actions import lookup
from guided_sfm.db.models import EditSetRow, Presence, Version, utcnow
from guided_sfm.db.session import read_only

WINDOW_SECONDS = 30  # design.md v1.1: "everyone seen in the last 30 s"


def report(session: Session, sessions: sessionmaker[Session], project_id: int, user_id: int,
           edit_set_id: int | None, version_id: int | None) -> list[Presence]:
    """Record where the user is now and return everyone seen in the window, the caller included,
    by username. `session` only reads (the checks, then the answer in a fresh transaction that
    sees the new row); the row is written by one upsert in a short transaction of its own, safe
    against the user's own parallel reports."""
    if edit_set_id is not None:
        lookup.in_project(session, EditSetRow, project_id, edit_set_id)
    if version_id is not None:
        lookup.in_project(session, Version, project_id, version_id)
    session.rollback()  # end the read before the write, so the answer's read sees it
    with sessions() as writer:
        _upsert(writer, {"project_id": project_id, "user_id": user_id, "edit_set_id": edit_set_id,
                         "version_id": version_id, "seen_at": utcnow()})
        writer.commit()
    read_only(session)
    return here(session, project_id)


def _upsert(session: Session, values: dict) -> None:
    insert = pg_insert if session.get_bind().dialect.name == "postgresql" else sqlite_insert
    statement = insert(Presence).values(**values)
    session.execute(statement.on_conflict_do_update(
        index_elements=["project_id", "user_id"],
        set_={k: statement.excluded[k] for k in ("edit_set_id", "version_id", "seen_at")}))


def here(session: Session, project_id: int) -> list[Presence]:
    cutoff = utcnow() - timedelta(seconds=WINDOW_SECONDS)
    query = select(Presence).where(Presence.project_id == project_id, Presence.seen_at >= cutoff)
    rows = list(session.scalars(query.execution_options(populate_existing=True)))
    return sorted(rows, key=lambda row: row.user.username)
