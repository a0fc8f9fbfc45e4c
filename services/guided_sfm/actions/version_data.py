"""Read a version's workspace in REST terms (SQL image ids): scene, pairs, preview, compare."""

from __future__ import annotations

import hashlib
import json
import threading
from collections import OrderedDict
from collections.abc import Callable
from contextlib import ExitStack
from dataclasses import replace
from typing import Any

from sqlalchemy.orm import Session

from guided_sfm.actions.ids import IdMap
from guided_sfm.core.edits import parse_edits
from guided_sfm.core.topdown import decimate_points
from guided_sfm.core.triage.of_workspace import triage_workspace
from guided_sfm.core.workspace import (
    DATABASE,
    EDITS,
    JOINED,
    META,
    PRUNING,
    SCENE,
    SPARSE,
    Workspace,
)
from guided_sfm.db import queries
from guided_sfm.db.models import EditSetRow, Version
from guided_sfm.storage import Store

READ = (DATABASE, SPARSE + "/", SCENE, META, EDITS, PRUNING, JOINED)  # all a reader needs: not the vocab tree

# The point layer's level of detail, chosen here: a scene keeps up to 20,000 points; above
# LARGE_SCENE_CAMERAS cameras the editor's first draw gets half of them (grid-decimated), and a
# client asks for more (up to all that are kept) with ?max_points=.
FULL_POINTS, LARGE_SCENE_POINTS, LARGE_SCENE_CAMERAS = 20_000, 10_000, 300


def point_budget(num_cameras: int) -> int:
    """The scene API's default number of points for a scene of this many cameras."""
    return LARGE_SCENE_POINTS if num_cameras > LARGE_SCENE_CAMERAS else FULL_POINTS


def _workspace(stack: ExitStack, store: Store, version: Version) -> Workspace:
    """The version's workspace for the length of the stack (fetched from the store if need be)."""
    return Workspace(stack.enter_context(store.reading(version.path, only=READ)))


class _VersionCache:
    """Answers computed from recent versions: a version never changes, and its scene (thousands
    of points) or its triage costs far more to build than to send. Keyed by the version's unique
    artifact key and the build's arguments."""

    def __init__(self, build: Callable[..., Any], size: int = 32) -> None:
        self.build, self.size = build, size
        self.entries, self.lock = OrderedDict[str, Any](), threading.Lock()

    def get(self, session: Session, store: Store, version: Version, *args: Any) -> Any:
        key = f"{store!r}:{version.path}|{[_token(arg) for arg in args]}"
        with self.lock:
            if key in self.entries:
                self.entries.move_to_end(key)
                return self.entries[key]
        data = self.build(session, store, version, *args)
        with self.lock:
            self.entries[key] = data
            while len(self.entries) > self.size:
                self.entries.popitem(last=False)
        return data


def _token(arg: Any) -> str:
    """An argument as a cache key: a version by its artifact key, a mapping (an edit set body, the
    image rows) by its digest."""
    if isinstance(arg, dict):
        return hashlib.sha256(json.dumps(arg, sort_keys=True).encode()).hexdigest()
    return str(getattr(arg, "path", None) or repr(arg))


def _scene_bytes(session: Session, store: Store, version: Version, max_points: int | None = None) -> bytes:
    return json.dumps(scene(session, store, version, max_points), separators=(",", ":")).encode()


scene_json = _VersionCache(_scene_bytes).get


def scene(session: Session, store: Store, version: Version,
          max_points: int | None = None) -> dict[str, Any]:
    """The scene with its point layer at max_points (None: the server's level of detail);
    `points` adds `total` (points kept with the version), `max_points` and `cell` (the grid's
    cell in frame units, 0 when nothing was dropped)."""
    with ExitStack() as stack:
        workspace = _workspace(stack, store, version)
        ids = IdMap.load(session, version.project_id, workspace)
        topdown = workspace.scene()
    budget = point_budget(len(topdown.cameras)) if max_points is None else max_points
    kept, cell = decimate_points(topdown.points_xy, budget)
    data = replace(topdown, points_xy=kept).to_dict()
    data["points"] |= {"total": len(topdown.points_xy), "max_points": budget, "cell": round(cell, 6)}
    data["cameras"] = ids.rows(data["cameras"])
    return data


def _suspects(session: Session, store: Store, version: Version) -> dict[str, Any]:
    """Triage in REST ids; images without an SQL row are left out (see ids.py)."""
    with ExitStack() as stack:
        workspace = _workspace(stack, store, version)
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


def _verified(_session: Session, store: Store, version: Version) -> tuple[dict[str, int], list]:
    """(COLMAP image id by name, sorted verified pairs with inliers) of a version: it never changes."""
    with store.reading(version.path, only=(DATABASE,)) as root:
        workspace = Workspace(root)
        return workspace.image_ids(), sorted(workspace.verified_pairs().items())


# the matches panel pages through one camera's pairs: read a version's database once, not per
# page (from S3 a read fetches the whole database); the REST ids come from the rows each time
_verified_cache = _VersionCache(_verified, size=8).get


def pairs(session: Session, store: Store, version: Version, image_id: int | None) -> list[dict]:
    colmap_by_name, verified = _verified_cache(session, store, version)
    ids = IdMap(queries.image_ids_by_name(session, version.project_id), colmap_by_name)
    return [{"image_id1": id1, "image_id2": id2, "num_inliers": inliers}
            for (id1, id2), inliers in ids.pairs_with(verified)
            if image_id is None or image_id in (id1, id2)]


def preview(session: Session, store: Store, row: EditSetRow, base: Version) -> dict[str, Any]:
    """What applying the edit set would delete; nothing is written. Cached by the base, the body
    and the project's image rows (the REST ids): shown again (another viewer, a reload, the
    review) it reads nothing of the version."""
    return _preview_cache(session, store, base, row.body, queries.image_ids_by_name(session, base.project_id))


def _preview(_session: Session, store: Store, base: Version, body: dict,
             sql_by_name: dict[str, int]) -> dict[str, Any]:
    with store.reading(base.path, only=(DATABASE, SPARSE + "/", SCENE)) as root:  # pairs, evidence, frame
        workspace = Workspace(root)
        ids = IdMap(sql_by_name, workspace.image_ids())
        outcome = workspace.preview(parse_edits(ids.edits_body(body), workspace.image_ids()))
    return {
        "pairs_to_delete": ids.pairs(outcome.deleted),
        "components_before": outcome.components_before,
        "components_after": outcome.components_after,
        "removed_by_test": outcome.removed_by_test,
        "kept_to_connect": ids.pairs(outcome.kept_to_connect),
        "reasons": [{"pair": list(pair), "tests": list(tests)}
                    for pair, tests in sorted(ids.pairs_with(outcome.reasons.items()))],
    }


_preview_cache = _VersionCache(_preview).get


def _ids(session: Session, store: Store, version: Version) -> IdMap:
    """REST <-> COLMAP ids of a version: its names from the cached database read, the rows now."""
    colmap_by_name, _ = _verified_cache(session, store, version)
    return IdMap(queries.image_ids_by_name(session, version.project_id), colmap_by_name)


def compare(session: Session, store: Store, version: Version, other: Version) -> dict[str, Any]:
    return {"cameras": _ids(session, store, other).rows(_compare_cache(session, store, version, other))}


def _compare(session: Session, store: Store, version: Version, other: Version) -> list[dict]:
    """Rows in COLMAP ids of the other's images: two versions and the rounds between them never
    change, so a compare asked again reads nothing."""
    edited = set().union(*(_edited(store, v) for v in _between(session, version, other)))
    with store.reading(version.path, only=(SPARSE + "/",)) as this, \
            store.reading(other.path, only=(SPARSE + "/",)) as that:
        return Workspace(this).compare(Workspace(that), edited)


_compare_cache = _VersionCache(_compare).get


def _edited(store: Store, version: Version) -> set[str]:
    """Names of the images the round that made the version edited."""
    with store.reading(version.path, only=(DATABASE, EDITS, JOINED)) as root:  # see touched_images
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
