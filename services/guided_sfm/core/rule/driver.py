"""Algorithm 1 (design.md) and the default rule: pairs to delete for an edit set, with the tests
that removed them (docs/pruning-rule.md). The edit set comes checked (core.edits.parse_edits)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from itertools import chain

import numpy as np
import shapely

from guided_sfm.core.errors import InvalidFrustum, InvalidInput
from guided_sfm.core.match_graph import components
from guided_sfm.core.rule.evidence import Evidence, flat_matches
from guided_sfm.core.rule.frustum import frustum_polygons
from guided_sfm.core.rule.match_placement import placement_test
from guided_sfm.core.rule.motion import place
from guided_sfm.core.rule.relative_pose import relative_pose_test
from guided_sfm.core.rule.relative_rotation import rotation_test
from guided_sfm.core.rule.tolerances import Tolerances
from guided_sfm.core.types import (
    DEFAULT_RULE,
    PAPER_RULE,
    CameraEdit,
    EditSet,
    PairKey,
    PruneResult,
    TopDownScene,
    pair_key,
)

FRUSTUM = "frustum"
PLACEMENT = "placement"
ROTATION = "rotation"
RELATIVE_POSE = "relative_pose"
MANUAL = "manual"

PlacedPose = tuple[float, float, float, float | None, float]  # x, y, yaw_deg, fov_deg, range


def _manual_pairs(edits: EditSet, pairs: Mapping[PairKey, int]) -> list[PairKey]:
    """The manual deletions as canonical keys; each must be a verified pair of this version (the
    parser knows the images, not the pairs)."""
    keys = []
    for a, b in edits.delete_pairs:
        key = pair_key(a, b)
        if key not in pairs:
            raise InvalidInput(f"manual deletion ({a}, {b}) is not a verified pair")
        keys.append(key)
    return keys


def placed_poses(scene: TopDownScene, moved: Mapping[int, CameraEdit],
                 range_scale: float = 1.0) -> dict[int, PlacedPose]:
    """2D pose (frame units, deg) of every placed camera: the edit if moved, else the model's.

    range_scale multiplies the scene's default ranges, never a range the edit gives.
    """
    poses: dict[int, PlacedPose] = {}
    for camera in scene.cameras:
        edit = moved.get(camera.image_id)
        default_range = None if camera.range is None else camera.range * range_scale
        if edit is not None:
            fov = camera.fov_deg if edit.fov_deg is None else edit.fov_deg
            range_ = default_range if edit.range is None else edit.range
            poses[camera.image_id] = (edit.x, edit.y, edit.yaw_deg, fov, range_)
        elif camera.registered and camera.x is not None:
            poses[camera.image_id] = (camera.x, camera.y, camera.yaw_deg, camera.fov_deg,
                                      default_range)
    return poses


def _tested_pairs(pairs: Mapping[PairKey, int], moved: Mapping[int, CameraEdit],
                  poses: Mapping[int, PlacedPose]) -> np.ndarray:
    """(P, 2) pairs, sorted, with at least one moved member and both members placed."""
    flat = np.fromiter(chain.from_iterable(pairs), dtype=np.int64, count=2 * len(pairs))
    keys = np.sort(flat.reshape(-1, 2), axis=1)
    moved_ids = np.fromiter(moved, dtype=np.int64, count=len(moved))
    placed_ids = np.fromiter(poses, dtype=np.int64, count=len(poses))
    touched = np.isin(keys, moved_ids).any(axis=1)
    placed = np.isin(keys, placed_ids).all(axis=1)
    tested = keys[touched & placed]
    return tested[np.lexsort((tested[:, 1], tested[:, 0]))]


def _triangles(ids: np.ndarray, poses: Mapping[int, PlacedPose]) -> np.ndarray:
    """One frustum polygon per id, built once."""
    values = np.array([poses[int(i)] for i in ids], dtype=object).reshape(-1, 5)
    missing_fov = [int(i) for i, fov in zip(ids, values[:, 3], strict=True) if fov is None]
    if missing_fov:  # the scene's value, not the user's: an image without intrinsics
        raise InvalidFrustum(f"camera {missing_fov[0]} has no field of view; give fov_deg")
    return frustum_polygons(*(values[:, k].astype(float) for k in range(5)))


def frustum_test(tested: np.ndarray, poses: Mapping[int, PlacedPose]) -> np.ndarray:
    """Mask over (P, 2) pairs whose frustum triangles do not intersect (2D frame)."""
    if len(tested) == 0:
        return np.zeros(0, dtype=bool)
    ids, index = np.unique(tested, return_inverse=True)
    triangles = _triangles(ids, poses)
    shapely.prepare(triangles)  # each triangle meets many partners; GEOS reuses its index
    a, b = index.reshape(-1, 2).T
    bounds = shapely.bounds(triangles)
    # Disjoint boxes cannot intersect; numpy rejects them cheaper than a GEOS call each.
    near = np.all((bounds[a, :2] <= bounds[b, 2:]) & (bounds[b, :2] <= bounds[a, 2:]), axis=1)
    apart = ~near
    apart[near] = ~shapely.intersects(triangles[a[near]], triangles[b[near]])
    return apart


@dataclass(frozen=True)
class RuleInput:
    """What a rule decides on: the tested pairs, every placed 2D pose, and the default rule's extras."""

    tested: np.ndarray  # (P, 2) sorted pairs with a moved member, both members placed
    poses: Mapping[int, PlacedPose]
    scene: TopDownScene
    moved: Mapping[int, CameraEdit]
    tolerances: Tolerances
    evidence: Evidence | None


def _paper_rule(rule_input: RuleInput) -> dict[str, np.ndarray]:
    return {FRUSTUM: frustum_test(rule_input.tested, rule_input.poses)}


def _default_rule(rule_input: RuleInput) -> dict[str, np.ndarray]:
    """Match placement, relative pose and relative rotation where the pair has evidence, else the
    frustum."""
    tested, evidence = rule_input.tested, rule_input.evidence
    if evidence is None:
        return _paper_rule(rule_input)
    if not evidence.rows:  # no tested camera is in the model (e.g. all in a smaller one)
        nothing = np.zeros(len(tested), dtype=bool)
        return {**_paper_rule(rule_input), PLACEMENT: nothing, RELATIVE_POSE: nothing,
                ROTATION: nothing}
    flat = flat_matches(evidence, tested)
    placement = place(rule_input.scene, rule_input.moved, evidence)
    tolerances = rule_input.tolerances
    placed_out, judged, _ = placement_test(flat, placement, evidence, tolerances)
    shifted_out, _, _ = relative_pose_test(flat, placement, evidence, tolerances)
    rotated_out, _, _ = rotation_test(flat, placement, evidence, tolerances,
                                      placed_out | shifted_out)
    frustum_out = np.zeros(len(tested), dtype=bool)
    frustum_out[~judged] = frustum_test(tested[~judged], rule_input.poses)
    return {FRUSTUM: frustum_out, PLACEMENT: placed_out, RELATIVE_POSE: shifted_out,
            ROTATION: rotated_out}


RULE_TESTS: dict[str, Callable[[RuleInput], dict[str, np.ndarray]]] = {
    PAPER_RULE: _paper_rule,
    DEFAULT_RULE: _default_rule,
}


def prune_pairs(scene: TopDownScene, edits: EditSet, pairs: Mapping[PairKey, int],
                evidence: Evidence | None = None) -> PruneResult:
    """Pairs (COLMAP image ids) the edit set's rule deletes, each with the tests that removed it.

    Without evidence (see core.evidence) the default rule can only run the frustum test.
    """
    rule = RULE_TESTS[edits.rule]
    tolerances = Tolerances(**edits.tolerances)
    moved = {edit.image_id: edit for edit in edits.cameras}
    manual = _manual_pairs(edits, pairs)
    poses = placed_poses(scene, moved, tolerances.range_scale)
    tested = _tested_pairs(pairs, moved, poses)
    reasons: dict[PairKey, tuple[str, ...]] = {}
    verdicts = rule(RuleInput(tested, poses, scene, moved, tolerances, evidence))
    for test, removed in verdicts.items():
        _add_reason(reasons, zip(*tested[removed].T.tolist(), strict=True), test)
    kept = links_to_keep(pairs, reasons, manual)  # (the paper's rule has no placement test)
    for key in kept:
        del reasons[key]
    _add_reason(reasons, dict.fromkeys(manual), MANUAL)
    return PruneResult(deleted=sorted(reasons), reasons=reasons, kept=kept)


def links_to_keep(pairs: Mapping[PairKey, int], reasons: Mapping[PairKey, tuple[str, ...]],
                  manual: list[PairKey]) -> list[PairKey]:
    """Cut pairs to keep so that the match-placement test alone never cuts a group of images off.

    Kept: the pairs that test alone cut (not the relative-pose test, not the rotation test's
    epipolar stage, not the user by hand) and that join two parts the cuts separated. Its angle
    measures the user's placement error as much as the pair; with no link left, a group of cameras
    cannot be registered at all, let alone where the user put it. All such links are kept: one
    alone registers a group poorly.
    """
    manual_keys = set(manual)
    after = {image_id: index
             for index, group in enumerate(components(pairs, set(reasons) | manual_keys))
             for image_id in group}
    return sorted(key for key, tests in reasons.items()
                  if tests == (PLACEMENT,) and key not in manual_keys
                  and after[key[0]] != after[key[1]])


def _add_reason(reasons: dict[PairKey, tuple[str, ...]], keys, test: str) -> None:
    if not reasons:
        reasons.update(dict.fromkeys(keys, (test,)))
        return
    for key in keys:
        reasons[key] = reasons.get(key, ()) + (test,)
