"""The relative-pose test: do the placements undo a relative pose that the pair's own matches hold?

Where a pair's matches agree with the model (its 3D points, left where they are, land on the
partner's keypoints), the model's relative pose of the two cameras is what those matches say, in
model units. When the placements change that relative pose by more than the user's uncertainty
allows, the matches tie the two cameras together where the user says they were not, so the pair
is removed. The match-placement test measures the same change as an angle, but the user's yaw error
turns every carried point by the same angle, so between twin objects a true pair's angle and a
false pair's overlap. Here the same yaw error moves the partner by an amount that scales with the
pair's distance, and a placement's position error adds at most one range share per moved member.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from guided_sfm.core.geometry import camera_centers, segment_median, yaw_slack_deg
from guided_sfm.core.rule.evidence import Evidence, FlatMatches, Verdicts
from guided_sfm.core.rule.match_placement import carried_angles
from guided_sfm.core.rule.motion import Motions
from guided_sfm.core.rule.tolerances import Tolerances

# A pair agrees with the model when its median carried point lands within this multiple of the
# epipolar tolerance: the model's inlier pairs sit near 0.1-1.5 deg, the others at tens of degrees.
AGREEMENT_FACTOR = 2.0


def partner_offsets(cam_from_world_rotations: np.ndarray, cam_from_world_translations: np.ndarray,
                    rows: np.ndarray) -> np.ndarray:
    """(P, 2, 3): per pair, each member's partner centre in that member's camera frame."""
    rotations, translations = cam_from_world_rotations, cam_from_world_translations
    centers = camera_centers(rotations, translations)
    offsets = []
    for own, other in ((0, 1), (1, 0)):
        offsets.append(np.einsum("pij,pj->pi", rotations[rows[:, own]], centers[rows[:, other]])
                       + translations[rows[:, own]])
    return np.stack(offsets, axis=1)


def without_motion(motions: Motions, evidence: Evidence) -> Motions:
    """No camera moved: every member at its model pose."""
    count = len(motions.moved)
    return dataclasses.replace(motions, motion_rotations=np.tile(np.eye(3), (count, 1, 1)),
                               motion_translations=np.zeros((count, 3)),
                               cam_rotations=evidence.rotations,
                               cam_translations=evidence.translations,
                               moved=np.zeros(count, dtype=bool))


def relative_pose_test(flat: FlatMatches, motions: Motions, evidence: Evidence,
                       tolerances: Tolerances) -> Verdicts:
    """Verdicts by shift / allowed shift per tested pair; pairs that do not agree with the model,
    or have too few 3D points, get none.

    Ranges are the scene's (median point depth, model units), neither `range_scale` nor an
    edit's own range: they size the uncertainty of a placement, not a frustum.
    """
    count = len(flat.counts)
    angles, pairs = carried_angles(flat, without_motion(motions, evidence), evidence)
    enough = np.bincount(pairs, minlength=count) >= tolerances.placement_min_points
    agrees = segment_median(angles, pairs, count) < AGREEMENT_FACTOR * tolerances.epipolar_deg
    judged = enough & agrees  # (carried_angles has no points for a member outside the model)
    ratio = np.full(count, np.nan)
    rows = flat.rows[judged]
    if len(rows) == 0:
        return Verdicts(np.zeros(count, dtype=bool), judged, ratio)
    model_offsets = partner_offsets(evidence.rotations, evidence.translations, rows)
    placed_offsets = partner_offsets(motions.cam_rotations, motions.cam_translations, rows)
    # Remove only when the change is too large seen from both members. With one member moved the
    # unmoved one's view sees just the moved centre's shift, which no yaw error explains; the
    # yaw term below matters when both moved.
    shift = np.linalg.norm(placed_offsets - model_offsets, axis=2).min(axis=1)
    yaw_rad = np.radians(yaw_slack_deg(tolerances.rotation_deg, tolerances.yaw_uncertainty_deg,
                                       motions.moved_members(rows)))
    # the chord a yaw error sweeps at the pair's 3D distance (>= the horizontal one: lenient)
    distance = np.linalg.norm(model_offsets, axis=2).min(axis=1)
    allowed = (tolerances.position_share * (motions.ranges[rows] * motions.moved[rows]).sum(axis=1)
               + 2 * np.sin(yaw_rad / 2) * distance)
    ratio[judged] = shift / np.maximum(allowed, 1e-12)
    return Verdicts(judged & (ratio > 1.0), judged, ratio)
