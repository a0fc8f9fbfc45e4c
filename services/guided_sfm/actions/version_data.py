"""Read a version's workspace in REST terms (SQL image ids): scene, pairs, preview, compare."""

from __future__ import annotations

import json
import threading
from collections import OrderedDict
from typing import Any

from sqlalchemy.orm import Session

from guided_sfm.actions.ids import IdMap
from guided_sfm.core.edits import parse_edits
from guided_sfm.core.triage.of_workspace import triage_workspace
from guided_sfm.core.workspace import Workspace
from guided_sfm.db.models import EditSetRow, Version
from guided_sfm.storage import ArtifactStore


def _workspace(store: ArtifactStore, version: Version) -> Workspace:
    return Workspace(store.version_dir(version.path))


class _VersionCache:
    """Answers computed from recent versions: a version never changes, and its scene (thousands
    of points) or its triage costs far more to build than to send. Keyed by the version's unique
    artifact path."""

    def __init__(self, build, size: int = 32) -> None:
        self.build, self.size = build, size
        self.entries, self.lock = OrderedDict[str, Any](), threading.Lock()

    def get(self, session: Session, store: ArtifactStore, version: Version) -> Any:
        key = str(store.version_dir(version.path))
        with self.lock:
            if key in self.entries:
                self.entries.move_to_end(key)
                return self.entries[key]
        data = self.build(session, store, version)
        with self.lock:
            self.entries[key] = data
            while len(self.entries) > self.size:
                self.entries.popitem(last=False)
        return data


def _scene_bytes(session: Session, store: ArtifactStore, version: Version) -> bytes:
    return json.dumps(scene(session, store, version), separators=(",", ":")).encode()


scene_json = _VersionCache(_scene_bytes).get


def scene(session: Session, store: ArtifactStore, version: Version) -> dict[str, Any]:
    workspace = _workspace(store, version)
    ids = IdMap.load(session, version.project_id, workspace)
    data = workspace.scene().to_dict()
    data["cameras"] = ids.rows(data["cameras"])
    return data


def _suspects(session: Session, store: ArtifactStore, version: Version) -> dict[str, Any]:
    """Triage in REST ids; images without an SQL row are left out (see ids.py)."""
    workspace = _workspace(store, version)
    ids = IdMap.load(session, version.project_id, workspace)
    data = triage_workspace(workspace).to_dict()
    runs = []
    for run in data["runs"]:
        image_ids = [ids.to_sql[i] for i in run["image_ids"] if i in ids.to_sql]
        if not image_ids:
            continue
        proposal = run["proposal"] and {"cameras": ids.rows(run["proposal"]["cameras"])}
        runs.append({**run, "image_ids": image_ids, "proposal": proposal})
    return {"suspects": ids.rows(data["suspects"]), "runs": runs}


suspects = _VersionCache(_suspects).get


def pairs(session: Session, store: ArtifactStore, version: Version, image_id: int | None) -> list[dict]:
    workspace = _workspace(store, version)
    ids = IdMap.load(session, version.project_id, workspace)
    return [{"image_id1": id1, "image_id2": id2, "num_inliers": inliers}
            for (id1, id2), inliers in ids.pairs_with(sorted(workspace.verified_pairs().items()))
            if image_id is None or image_id in (id1, id2)]


def preview(session: Session, store: ArtifactStore, row: EditSetRow, base: Version) -> dict[str, Any]:
    """What applying the edit set would delete; nothing is written."""
    workspace = _workspace(store, base)
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


def compare(session: Session, store: ArtifactStore, version: Version, other: Version) -> dict[str, Any]:
    ids = IdMap.load(session, other.project_id, _workspace(store, other))
    edited = set().union(*(_workspace(store, v).touched_names() for v in _between(session, version, other)))
    rows = _workspace(store, version).compare(_workspace(store, other), edited)
    return {"cameras": ids.rows(rows)}


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
