"""The match-placement test (reason `placement`): does a pair's own evidence agree with where the
user put the cameras?

Each member's observed 3D points (those of the pair's inlier matches) are carried rigidly with that
member's motion, looked at from the partner at its placed pose, and compared with the partner's matched
keypoints. A true pair's carried points land on its matches (within ~10 deg); a false pair's, made
of look-alike texture elsewhere, land tens of degrees away.
"""

from __future__ import annotations

import numpy as np

from guided_sfm.core.geometry import segment_quantile, yaw_slack_deg
from guided_sfm.core.rule.evidence import Evidence, FlatMatches, Verdicts
from guided_sfm.core.rule.motion import Motions
from guided_sfm.core.rule.tolerances import Tolerances

# The share of a pair's carried angles that must exceed the tolerance for a removal. design.md
# calls a pair false when at least half of its matches are wrong; twins' true pairs carry up to
# half look-alike matches, whose angles pushed the median over (5 true pairs in twins' round 1 at
# the median, none at 0.4, for one false pair that only this test removed).
PLACEMENT_QUANTILE = 0.4


def _partner_from_own(motions: Motions, own_rows: np.ndarray, partner_rows: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Per pair: partner camera (placed) <- placed world <- own model world, as (R, t)."""
    partner = motions.cam_rotations[partner_rows]
    rotation = partner @ motions.motion_rotations[own_rows]
    translation = np.einsum("pij,pj->pi", partner, motions.motion_translations[own_rows])
    return rotation, translation + motions.cam_translations[partner_rows]


def carried_angles(flat: FlatMatches, motions: Motions, evidence: Evidence
                   ) -> tuple[np.ndarray, np.ndarray]:
    """(angles deg, pair index) of every match side whose keypoint has a 3D point."""
    angles, pairs = [], []
    in_model = (flat.rows >= 0).all(axis=1)
    for side in (0, 1):
        rotation, translation = _partner_from_own(motions, flat.rows[:, side] * in_model,
                                                  flat.rows[:, 1 - side] * in_model)
        own, other = flat.keypoints[:, side], flat.keypoints[:, 1 - side]
        has_point = ~np.isnan(evidence.points[own, 0])
        pair = flat.pair[has_point]
        per_pair = np.bincount(pair, minlength=len(flat.counts))
        # matches are grouped by pair, so repeating each pair's transform lines up with them
        in_partner = np.einsum("nij,nj->ni", np.repeat(rotation, per_pair, axis=0),
                               evidence.points[own[has_point]]) + np.repeat(translation, per_pair, axis=0)
        cos = np.einsum("ni,ni->n", in_partner, evidence.rays[other[has_point]])
        cos /= np.maximum(np.linalg.norm(in_partner, axis=1), 1e-12)
        angles.append(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))
        pairs.append(pair)
    return np.concatenate(angles), np.concatenate(pairs)


def placement_test(flat: FlatMatches, motions: Motions, evidence: Evidence,
                   tolerances: Tolerances) -> Verdicts:
    """Verdicts by the carried angle (deg, its PLACEMENT_QUANTILE) per tested pair; too few
    carried points: none."""
    count = len(flat.counts)
    angles, pairs = carried_angles(flat, motions, evidence)
    judged = np.bincount(pairs, minlength=count) >= tolerances.placement_min_points
    angle = segment_quantile(angles, pairs, count, PLACEMENT_QUANTILE)
    moved = motions.moved_members(flat.rows) * (flat.rows >= 0).all(axis=1)
    tolerance = yaw_slack_deg(tolerances.placement_deg, tolerances.yaw_uncertainty_deg, moved)
    return Verdicts(judged & (angle > tolerance), judged, angle)
