"""The relative-pose test: does the placement undo a relative pose that the pair's own matches hold?

Where a pair's matches agree with the model (its 3D points, left where they are, land on the
partner's keypoints), the model's relative pose of the two cameras is what those matches say, in
model units. When the placement changes that relative pose by more than the user's uncertainty
allows, the matches tie the two cameras together where the user says they were not, so the pair
is cut. The match-placement test measures the same change as an angle, but the user's yaw error
turns every carried point by the same angle, so between twin objects a true pair's angle and a
false pair's overlap. Here the same yaw error moves the partner by an amount that scales with the
pair's distance, and the placement's position error adds at most one range share per moved member.
"""

from __future__ import annotations

import numpy as np

from guided_sfm.core.evidence import Evidence, FlatMatches
from guided_sfm.core.match_placement import carried_angles
from guided_sfm.core.placement import Placement, segment_median
from guided_sfm.core.tolerances import Tolerances

# A pair agrees with the model when its median carried point lands within this multiple of the
# epipolar tolerance: the model's inlier pairs sit near 0.1-1.5 deg, the others at tens of degrees.
AGREEMENT_FACTOR = 2.0


def partner_offsets(rotations: np.ndarray, translations: np.ndarray, rows: np.ndarray
                    ) -> np.ndarray:
    """(P, 2, 3): per pair, each member's partner centre in that member's camera frame."""
    centers = -np.einsum("nji,nj->ni", rotations, translations)
    offsets = []
    for own, other in ((0, 1), (1, 0)):
        offsets.append(np.einsum("pij,pj->pi", rotations[rows[:, own]], centers[rows[:, other]])
                       + translations[rows[:, own]])
    return np.stack(offsets, axis=1)


def relative_pose_test(flat: FlatMatches, placement: Placement, unmoved: Placement,
                       evidence: Evidence, tolerances: Tolerances
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(removed, evaluated, shift / allowed shift) per tested pair; pairs that do not agree with
    the model, or have too few 3D points, get no verdict (NaN)."""
    count = len(flat.counts)
    angles, pairs = carried_angles(flat, unmoved, evidence)
    enough = np.bincount(pairs, minlength=count) >= tolerances.placement_min_points
    agrees = segment_median(angles, pairs, count) < AGREEMENT_FACTOR * tolerances.epipolar_deg
    evaluated = enough & agrees & (flat.rows >= 0).all(axis=1)
    ratio = np.full(count, np.nan)
    rows = flat.rows[evaluated]
    if len(rows) == 0:
        return np.zeros(count, dtype=bool), evaluated, ratio
    model = partner_offsets(evidence.rotations, evidence.translations, rows)
    placed = partner_offsets(placement.rotations, placement.translations, rows)
    # Seen from either member the change is the same up to that member's yaw error: the smaller
    # of the two is the one the uncertainty below must explain.
    shift = np.linalg.norm(placed - model, axis=2).min(axis=1)
    moved = placement.moved[rows]
    yaw = np.radians(tolerances.rotation_deg
                     + tolerances.yaw_uncertainty_deg * np.maximum(moved.sum(axis=1) - 1, 0))
    allowed = (tolerances.position_share * (placement.ranges[rows] * moved).sum(axis=1)
               + 2 * np.sin(yaw / 2) * np.linalg.norm(model, axis=2).min(axis=1))
    ratio[evaluated] = shift / allowed
    return evaluated & (ratio > 1.0), evaluated, ratio
