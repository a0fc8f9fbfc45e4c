"""Read a version's workspace in REST terms (SQL image ids): scene, pairs, preview, compare."""

from __future__ import annotations

import json
import threading
from collections import OrderedDict
from contextlib import ExitStack
from typing import Any

from sqlalchemy.orm import Session

from guided_sfm.actions.ids import IdMap
from guided_sfm.core.edits import parse_edits
from guided_sfm.core.workspace import DATABASE, EDITS, META, PRUNING, SCENE, SPARSE, Workspace
from guided_sfm.db.models import EditSetRow, Version
from guided_sfm.storage import Store

READ = (DATABASE, SPARSE + "/", SCENE, META, EDITS, PRUNING)  # all a reader needs: not the vocab tree


def _workspace(stack: ExitStack, store: Store, version: Version) -> Workspace:
    """The version's workspace for the length of the stack (fetched from the store if need be)."""
    return Workspace(stack.enter_context(store.reading(version.path, only=READ)))


class _SceneCache:
    """Serialized scenes of recent versions: a version never changes, and its JSON (thousands of
    points) costs far more to build than to send. Keyed by the version's unique artifact key."""

    def __init__(self, size: int = 32) -> None:
        self.size, self.entries, self.lock = size, OrderedDict[str, bytes](), threading.Lock()

    def get(self, session: Session, store: Store, version: Version) -> bytes:
        key = f"{store!r}:{version.path}"
        with self.lock:
            if key in self.entries:
                self.entries.move_to_end(key)
                return self.entries[key]
        data = json.dumps(scene(session, store, version), separators=(",", ":")).encode()
        with self.lock:
            self.entries[key] = data
            while len(self.entries) > self.size:
                self.entries.popitem(last=False)
        return data


scene_json = _SceneCache().get


def scene(session: Session, store: Store, version: Version) -> dict[str, Any]:
    with ExitStack() as stack:
        workspace = _workspace(stack, store, version)
        ids = IdMap.load(session, version.project_id, workspace)
        data = workspace.scene().to_dict()
    data["cameras"] = ids.rows(data["cameras"])
    return data


def pairs(session: Session, store: Store, version: Version, image_id: int | None) -> list[dict]:
    with store.reading(version.path, only=(DATABASE,)) as root:
        workspace = Workspace(root)
        ids = IdMap.load(session, version.project_id, workspace)
        verified = workspace.verified_pairs()
    return [{"image_id1": id1, "image_id2": id2, "num_inliers": inliers}
            for (id1, id2), inliers in ids.pairs_with(sorted(verified.items()))
            if image_id is None or image_id in (id1, id2)]


def preview(session: Session, store: Store, row: EditSetRow, base: Version) -> dict[str, Any]:
    """What applying the edit set would delete; nothing is written."""
    with ExitStack() as stack:
        workspace = _workspace(stack, store, base)
        ids = IdMap.load(session, base.project_id, workspace)
        outcome = workspace.preview(parse_edits(ids.edits_body(row.body), workspace.image_ids()))
    return {
        "pairs_to_delete": ids.pairs(outcome.deleted),
        "components_before": outcome.components_before,
        "components_after": outcome.components_after,
        "removed_by_test": outcome.removed_by_test,
        "kept_to_connect": ids.pairs(outcome.kept_to_connect),
        "reasons": [{"pair": list(pair), "tests": list(tests)}
                    for pair, tests in sorted(ids.pairs_with(outcome.reasons.items()))],
    }


def compare(session: Session, store: Store, version: Version, other: Version) -> dict[str, Any]:
    with ExitStack() as stack:
        other_ws = _workspace(stack, store, other)
        ids = IdMap.load(session, other.project_id, other_ws)
        between = _between(session, version, other)
        edited = set().union(*(_edited(store, v) for v in between))
        rows = _workspace(stack, store, version).compare(other_ws, edited)
    return {"cameras": ids.rows(rows)}


def _edited(store: Store, version: Version) -> set[str]:
    """Names of the images the round that made the version edited."""
    with store.reading(version.path, only=(DATABASE, EDITS)) as root:
        return Workspace(root).touched_names()


def _lineage(session: Session, version: Version) -> list[Version]:
    """The version and its ancestors, newest first."""
    chain = [version]
    while chain[-1].parent_id is not None and len(chain) < 10_000:
        chain.append(session.get(Version, chain[-1].parent_id))
    return chain


def _between(session: Session, a: Version, b: Version) -> list[Version]:
    """The versions made after the last common ancestor of a and b, on either side: the rounds
    whose edits lie between them."""
    chain_a, chain_b = _lineage(session, a), _lineage(session, b)
    ids_a, ids_b = {v.id for v in chain_a}, {v.id for v in chain_b}
    return [v for v in chain_a if v.id not in ids_b] + [v for v in chain_b if v.id not in ids_a]
