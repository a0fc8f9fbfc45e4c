"""Carry a stale edit set onto the project's head: what the head still has is kept, the rest is
reported with the reason, and the edit set is saved as a new revision on the head."""

from __future__ import annotations

from typing import Any

from sqlalchemy.orm import Session

from guided_sfm.actions import edit_sets
from guided_sfm.actions.ids import IdMap
from guided_sfm.core.types import pair_key
from guided_sfm.core.workspace import DATABASE, Workspace
from guided_sfm.db import queries
from guided_sfm.db.models import EditSetRow, Project, Version
from guided_sfm.errors import Conflict
from guided_sfm.storage import Store


def rebase(session: Session, store: Store, project: Project, row: EditSetRow,
           if_match: str | None, user_id: int) -> tuple[EditSetRow, dict[str, Any]]:
    """(the edit set on the head, the report {from_version, to_version, carried, dropped})."""
    edit_sets.parse_if_match(if_match)
    head = project.head_version_id
    if head is None:
        raise Conflict(f"project {project.id} has no head version to rebase onto")
    old = row.base_version_id
    made = queries.applied_revisions(session, project.id).get((row.id, row.revision))
    if made is not None:
        raise Conflict(f"edit set {row.id} (revision {row.revision}) was applied already, making "
                       f"version {made}; it is not carried onto the head again")
    if old == head:
        return row, {"from_version": old, "to_version": head, "carried": _all(row.body), "dropped": []}
    body, report = carry(row.body, _head_view(session, store, project.id, head), head)
    saved = edit_sets.replace(session, project, row, {**body, "base_version_id": head}, if_match, user_id)
    return saved, {"from_version": old, "to_version": head, **report}


def _head_view(session: Session, store: Store, project_id: int, head: int) -> tuple[set, set]:
    """(REST ids of the head's images, its verified pairs as sorted REST id pairs)."""
    with store.reading(session.get(Version, head).path, only=(DATABASE,)) as root:
        workspace = Workspace(root)
        ids = IdMap.load(session, project_id, workspace)
        return set(ids.to_sql.values()), {tuple(p) for p in ids.pairs(workspace.verified_pairs())}


def carry(body: dict[str, Any], head_view: tuple[set, set], head: int) -> tuple[dict[str, Any], dict]:
    """The body's cameras and flags on images the head has, and its manual deletions of pairs the
    head still matches; the report names the rest and why."""
    images, pairs = head_view
    cameras = [c for c in body.get("cameras") or [] if c["image_id"] in images]
    flags = [i for i in body.get("flags") or [] if i in images]
    deletions = [p for p in body.get("delete_pairs") or [] if pair_key(*p) in pairs]
    dropped = [{"kind": "camera", "image_ids": [c["image_id"]], "reason": f"the image is not part of v{head}"}
               for c in body.get("cameras") or [] if c not in cameras]
    dropped += [{"kind": "flag", "image_ids": [i], "reason": f"the image is not part of v{head}"}
                for i in body.get("flags") or [] if i not in flags]
    dropped += [{"kind": "delete_pair", "image_ids": list(p),
                 "reason": f"v{head} no longer matches this pair (it was deleted already)"}
                for p in body.get("delete_pairs") or [] if p not in deletions]
    kept = {**body, "cameras": cameras, "flags": flags, "delete_pairs": deletions}
    return kept, {"carried": _all(kept), "dropped": dropped}


def _all(body: dict[str, Any]) -> dict[str, list]:
    return {"cameras": [c["image_id"] for c in body.get("cameras") or []],
            "delete_pairs": [list(p) for p in body.get("delete_pairs") or []],
            "flags": list(body.get("flags") or [])}
