"""Edit sets (drafts on a base version): validated at the edge, saved with optimistic concurrency,
queued for application on the head."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from sqlalchemy import case, update
from sqlalchemy.orm import Session

from guided_sfm import jobs
from guided_sfm.actions import lookup
from guided_sfm.core.edits import edits_to_json, parse_edits
from guided_sfm.core.errors import InvalidInput, UnknownImage
from guided_sfm.db import queries
from guided_sfm.db.models import MAX_ID, EditSetRow, Job, Project, Version, utcnow
from guided_sfm.errors import Conflict, PreconditionRequired


def validate(session: Session, project: Project, body: dict[str, Any]) -> dict[str, Any]:
    """The normalized body (REST image ids); raises naming the first problem found."""
    base_id = body.get("base_version_id")
    lookup.in_project(session, Version, project.id, base_id)
    ids = queries.image_ids_by_name(session, project.id)
    known = set(ids.values())
    edits = parse_edits(body, ids)
    flags = body.get("flags") or []
    for image_id in flags:
        if isinstance(image_id, bool) or not isinstance(image_id, int):
            raise InvalidInput(f"flags must be image ids, got {image_id!r}")
        if image_id not in known:
            raise UnknownImage(f"unknown image id {image_id} in flags")
    return {"base_version_id": base_id, **edits_to_json(edits), "flags": sorted(set(flags))}


def create(session: Session, project: Project, body: dict[str, Any], user_id: int) -> EditSetRow:
    clean = validate(session, project, body)
    row = EditSetRow(project_id=project.id, base_version_id=clean["base_version_id"], body=clean,
                     revision=1, updated_by_id=user_id, created_by_id=user_id)
    session.add(row)
    session.commit()
    return row


def parse_if_match(header: str | None) -> int:
    """The revision in If-Match (bare or quoted, weak tags too); 428 without one."""
    if header is None or not header.strip():
        raise PreconditionRequired("send If-Match: <revision> (the ETag of the edit set you changed)")
    raw = header.strip().removeprefix("W/").strip('"')
    if not raw.isdigit() or int(raw) > MAX_ID:  # a revision is a SQL integer: larger cannot match
        raise Conflict(f"If-Match {header[:40]!r} is not a revision of this edit set")
    return int(raw)


def replace(session: Session, project: Project, row: EditSetRow, body: dict[str, Any],
            if_match: str | None, user_id: int) -> EditSetRow:
    """Save a new revision only if the client saw the current one (compare-and-set in SQL)."""
    expected = parse_if_match(if_match)
    clean = validate(session, project, body)
    result = session.execute(
        update(EditSetRow).where(EditSetRow.id == row.id, EditSetRow.revision == expected)
        .values(body=clean, base_version_id=clean["base_version_id"], revision=expected + 1,
                updated_by_id=user_id, updated_at=utcnow(),
                # an approval holds for the revision it saw: a new one needs review again
                review_state=case((EditSetRow.review_state == "approved", "draft"),
                                  else_=EditSetRow.review_state))
    )
    if result.rowcount != 1:
        session.rollback()
        raise Conflict(f"edit set {row.id} was saved by someone else (revision {expected} is not current)")
    session.commit()
    session.refresh(row)
    return row


def delete(session: Session, row: EditSetRow) -> None:
    session.delete(row)
    session.commit()


def apply(session: Session, submit: Callable[[int], None], project: Project, row: EditSetRow,
          user_id: int, remap: bool, message: str | None = None) -> Job:
    """Queue the edit set's application; 409 unless it is based on the head (rebase it first)."""
    if not row.body.get("cameras") and not row.body.get("delete_pairs"):
        # An empty draft would make a version identical to its base: no job, no version.
        raise InvalidInput(f"nothing to apply: edit set {row.id} moves no camera and deletes no pair")
    if row.base_version_id != project.head_version_id:
        raise Conflict(f"edit set {row.id} is based on version {row.base_version_id}, but the head is "
                       f"version {project.head_version_id}; rebase it onto the head first "
                       f"(POST .../edits/{row.id}/rebase)")
    params = {"edit_set_id": row.id, "revision": row.revision, "body": row.body, "remap": remap,
              "message": message or None}
    return jobs.queue(session, submit, project, "apply", user_id, params, row.base_version_id)
