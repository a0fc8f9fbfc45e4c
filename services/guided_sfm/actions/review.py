"""Review of edit sets: submit, approve or request changes (never one's own), and the gate on apply.

Every state change is a conditional UPDATE on (state, revision), so a review of a revision that a
save replaced meanwhile, or two reviews at once, cannot both win.
"""

from __future__ import annotations

from sqlalchemy import select, update
from sqlalchemy.orm import Session

from guided_sfm.actions import notifications, webhooks
from guided_sfm.actions.activity import Actor, record
from guided_sfm.db.models import EditSetRow, Membership, Project, Review
from guided_sfm.errors import Conflict, Forbidden

SUBMITTABLE = ("draft", "changes_requested")
VERDICT_STATE = {"approve": "approved", "request_changes": "changes_requested"}


def authors(row: EditSetRow) -> set[int]:
    """Who wrote the edit set: its creator and whoever saved its current revision."""
    return {user_id for user_id in (row.created_by_id, row.updated_by_id) if user_id is not None}


def _move(session: Session, row: EditSetRow, allowed: tuple[str, ...], state: str) -> None:
    result = session.execute(
        update(EditSetRow).where(EditSetRow.id == row.id, EditSetRow.revision == row.revision,
                                 EditSetRow.review_state.in_(allowed)).values(review_state=state))
    if result.rowcount != 1:
        session.rollback()
        session.refresh(row)
        raise Conflict(f"edit set {row.id} is {row.review_state} at revision {row.revision}; "
                       f"this needs it {' or '.join(allowed)}")


def submit(session: Session, project: Project, row: EditSetRow, actor: Actor) -> EditSetRow:
    """draft or changes_requested -> in_review; the project's editors and owners are asked."""
    _move(session, row, SUBMITTABLE, "in_review")
    reviewers = set(session.scalars(select(Membership.user_id).where(
        Membership.project_id == project.id, Membership.role.in_(("editor", "owner")))))
    text = f"{actor.username} asks for a review of edit set {row.id} (revision {row.revision})"
    notifications.notify(session, reviewers - {actor.user_id}, project.id, "review_requested",
                         {"kind": "edit_set", "id": row.id}, text)
    record(session, project.id, actor, "submit", {"kind": "edit_set", "id": row.id},
           {"revision": row.revision}, commit=False)
    webhooks.emit(session, project.id, "edit_submitted",
                  {"edit_set_id": row.id, "revision": row.revision, "by": actor.username})
    session.commit()
    session.refresh(row)
    return row


def review(session: Session, project: Project, row: EditSetRow, actor: Actor, verdict: str,
           comment: str) -> Review:
    """A verdict on the current revision of an edit set in review, by someone who did not write it."""
    if actor.user_id in authors(row):
        raise Forbidden(f"you wrote edit set {row.id}; someone else with the editor or owner role reviews it")
    _move(session, row, ("in_review",), VERDICT_STATE[verdict])
    entry = Review(edit_set_id=row.id, reviewer_id=actor.user_id, verdict=verdict, comment=comment,
                   revision=row.revision)
    session.add(entry)
    session.flush()
    words = "approved" if verdict == "approve" else "requested changes on"
    text = f"{actor.username} {words} edit set {row.id}" + (f": {comment}" if comment else "")
    notifications.notify(session, authors(row) - {actor.user_id}, project.id, "reviewed",
                         {"kind": "edit_set", "id": row.id}, text)
    record(session, project.id, actor, "review", {"kind": "edit_set", "id": row.id},
           {"verdict": verdict, "revision": row.revision, "review_id": entry.id}, commit=False)
    webhooks.emit(session, project.id, "edit_reviewed",
                  {"edit_set_id": row.id, "revision": row.revision, "verdict": verdict,
                   "comment": comment, "by": actor.username})
    session.commit()
    session.refresh(row)
    return entry


def check_apply(project: Project, row: EditSetRow) -> None:
    """With `require_approval` on, only an approved edit set may be applied (409 naming why)."""
    if project.require_approval and row.review_state != "approved":
        raise Conflict(f"project {project.id} requires approval before apply, and edit set {row.id} "
                       f"is {row.review_state}; submit it and have another editor approve it")


def reviews_of(session: Session, edit_set_id: int) -> list[Review]:
    return list(session.scalars(select(Review).where(Review.edit_set_id == edit_set_id).order_by(Review.id)))
