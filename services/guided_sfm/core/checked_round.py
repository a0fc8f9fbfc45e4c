"""A checked re-map: after a round maps again, moved cameras that landed far from the user's
placements are judged once more on the new model (reason `check`), and the round maps again.

A false pair the rule could not judge on the base model (a look-alike pair whose own geometry is
ambiguous) can pull a moved camera back onto its fold during the re-map. On the new model that
pair agrees with the fold the placements undo, so the relative-pose test sees it. The user placed
once; the extra passes cost only mapping time, never another round of looking and placing.
"""

from __future__ import annotations

import dataclasses
import json
import os
from pathlib import Path

import numpy as np

from guided_sfm.core import colmap_db
from guided_sfm.core.remap import MapReport
from guided_sfm.core.rule.tolerances import Tolerances
from guided_sfm.core.sfm import RunContext
from guided_sfm.core.types import CameraEdit, EditSet, GroundFrame, PairKey, TopDownScene
from guided_sfm.core.workspace import Workspace

CHECK = "check"  # the reason of the pairs a check pass deletes
CHECK_PASSES = 2  # at most this many extra prune + map passes per round
# A camera is far from its placement beyond this many of its positional uncertainties
# (position_share x range, the rule's own allowance for the user's error).
CHECK_SIGMAS = 3.0
# The new model is in the base's frame only when the re-map could be aligned on cameras the round
# did not move (colmap_model.align_models needs 3); without them there is nothing to compare with.
MIN_ANCHORS = 3


def in_frame(placement: CameraEdit, source: GroundFrame, target: GroundFrame) -> CameraEdit:
    """The same placement expressed in another 2D frame (frames of two aligned models)."""
    point = source.origin + placement.x * source.x_axis + placement.y * source.y_axis
    yaw = np.radians(placement.yaw_deg)
    heading = np.cos(yaw) * source.x_axis + np.sin(yaw) * source.y_axis
    x, y = target.to_2d(point[None])[0]
    turned = np.degrees(np.arctan2(heading @ target.y_axis, heading @ target.x_axis))
    return dataclasses.replace(placement, x=float(x), y=float(y), yaw_deg=float(turned))


def far_from_placement(scene: TopDownScene, placements: list[CameraEdit],
                       position_share: float) -> list[CameraEdit]:
    """The placements (in scene's frame) whose camera is registered more than CHECK_SIGMAS x
    position_share x its range away from them."""
    by_id = {camera.image_id: camera for camera in scene.cameras}
    far = []
    for placement in placements:
        camera = by_id.get(placement.image_id)
        if camera is None or camera.x is None or camera.range is None:
            continue  # not in the largest model: nothing to compare
        limit = CHECK_SIGMAS * position_share * (placement.range or camera.range)
        if np.hypot(camera.x - placement.x, camera.y - placement.y) > limit:
            far.append(placement)
    return far


def anchors(scene: TopDownScene, edits: EditSet) -> int:
    """Registered cameras of the scene that the edit set did not move."""
    moved = {placement.image_id for placement in edits.cameras}
    return sum(1 for c in scene.cameras if c.x is not None and c.image_id not in moved)


def _delete_in_place(ws: Workspace, pairs: list[PairKey]) -> None:
    staging = ws.database.with_suffix(".check")
    colmap_db.copy_without_pairs(ws.database, staging, pairs)
    os.replace(staging, ws.database)


def map_checked(ws: Workspace, edits: EditSet, run: RunContext = RunContext(),
                image_dir: Path | None = None, cold: bool = False
                ) -> tuple[MapReport, list[PairKey]]:
    """Map a pruned workspace again (Workspace.map_again), then up to CHECK_PASSES times: judge
    the pairs of the moved cameras that landed far from their placements on the new model,
    delete what the rule removes and map again. Returns the last map's report and the pairs the
    checks deleted (also added to pruning.json with the reason `check`)."""
    frame = ws.scene().frame  # the base's frame: the new workspace starts with its scene
    report = ws.map_again(run, image_dir, cold=cold)
    share = Tolerances(**edits.tolerances).position_share
    checked: list[PairKey] = []
    for _ in range(CHECK_PASSES):
        scene = ws.scene()
        if anchors(scene, edits) < MIN_ANCHORS:
            break
        far = far_from_placement(scene, [in_frame(c, frame, scene.frame) for c in edits.cameras],
                                 share)
        if not far:
            break
        outcome = ws.preview(dataclasses.replace(edits, cameras=far, delete_pairs=[]))
        if not outcome.deleted:
            break
        _delete_in_place(ws, outcome.deleted)
        checked.extend(outcome.deleted)
        report = ws.map_again(run, image_dir, cold=cold)
    if checked:
        _record(ws, checked)
    return report, sorted(checked)


def _record(ws: Workspace, checked: list[PairKey]) -> None:
    """Add the check's deletions to pruning.json (its deleted pairs and their reason)."""
    names = ws.image_names()
    record = json.loads(ws.pruning_file.read_text()) if ws.pruning_file.is_file() else {}
    named = [sorted((names[a], names[b])) for a, b in checked]
    record["deleted_pairs"] = sorted(record.get("deleted_pairs", []) + named)
    record.setdefault("removed_by_test", {})[CHECK] = len(named)
    record["checked_pairs"] = sorted(named)
    ws.pruning_file.write_text(json.dumps(record, indent=2))
