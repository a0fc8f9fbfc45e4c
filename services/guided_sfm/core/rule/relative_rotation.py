"""The relative-rotation test: can the pair's own matches be explained by the placed poses?

Cameras circling an object and facing its centre carry their points only a little when moved, so
the match-placement test cannot see that a pair matched look-alike sides 90 deg apart; the pair's
relative rotation can. Estimating that rotation and comparing it fails on weak, planar and
pure-rotation pairs, whose rotation is ill-determined, so both stages ask instead whether the
placed relative pose (its yaw free within the user's uncertainty, tilt from the model's gravity,
translation within a cone around the placed baseline) can explain the matches; ambiguity never
removes a pair.

1. Epipolar (every pair, vectorised): the RMS algebraic epipolar residual of the inlier rays under
   the best such pose, from one 9x9 moment matrix per pair (for E = [t]x R the residual sum is
   vec(E)^T M vec(E), quadratic in t); a pair above the limit is judged again by its median match
   under a reweighted fit, so a minority of look-alike matches in a true pair does not remove it.
2. Two-view (pairs the placements re-orient relative to the model, one at a time): the pair's own
   relative pose, from a homography where one explains the matches (planar or pure rotation; the
   plane's two solutions are told apart by the placed baseline) else from pycolmap's 5-point
   LO-RANSAC, against the nearest placed rotation. Inward-facing orbits need this stage: their
   epipolar lines run along the ring, so look-alike matches pass stage 1.
"""

from __future__ import annotations

import numpy as np
import pycolmap

from guided_sfm.core.geometry import rotation_angles_deg, rotations_about, segment_median, yaw_slack_deg
from guided_sfm.core.rule.evidence import Evidence, FlatMatches, Verdicts
from guided_sfm.core.rule.motion import Motions
from guided_sfm.core.rule.tolerances import Tolerances

# A pair whose homography transfers its rays this well is planar or a pure rotation.
HOMOGRAPHY_FIT_DEG = 0.5
RANSAC_MAX_ERROR = 4e-3  # ~2 px at a 500 px focal length, on unit rays
MIN_INLIER_SHARE = 0.7  # of the verified inliers, for the pair's own relative pose to count
YAW_STEPS = 15  # yaw samples across the allowed range; a residual minimum is wide for a true pair
RING = 16  # translation directions sampled on the rim of the placed baseline's cone
# A pair the RMS would remove is judged again: for each candidate rotation its translation is refitted
# this often, each match weighted 1 / its residual (deg, at least the floor): iteratively
# reweighted least squares towards the smallest absolute residuals, which strays pull little.
IRLS_STEPS, IRLS_FLOOR_DEG = 2, 0.05
RECHECKED_CANDIDATES = 5  # of the YAW_STEPS rotations, those with the lowest RMS
# A pair between two moved cameras is judged by its own two-view pose even where the model already
# agrees with the placements: a run folded as a whole (both members turned alike) keeps its relative
# rotation, and its look-alike pairs pass the epipolar stage along the ring. Strong pairs only: their
# pose is well determined, and the per-pair check stays within the preview's time. A vectorised
# linear (8-point) pose screens them first; noisy, it is trusted only when within half of
# two_view_deg of the placement (orbit round 1: a false pair at 12.8 deg linear was 61 deg off).
BOTH_MOVED_MIN_INLIERS = 60
# [t]x = sum_m t_m GENERATORS[m]
GENERATORS = np.array([[[0, 0, 0], [0, 0, -1], [0, 1, 0]],
                       [[0, 0, 1], [0, 0, 0], [-1, 0, 0]],
                       [[0, -1, 0], [1, 0, 0], [0, 0, 0]]], dtype=float)


def epipolar_moments(a: np.ndarray, b: np.ndarray, pair: np.ndarray, count: int) -> np.ndarray:
    """(P, 9, 9) per pair sum of (b kron a)(b kron a)^T over its rays a <-> b, sorted by pair."""
    kron = (b[:, :, None] * a[:, None, :]).reshape(-1, 9)
    bounds = np.cumsum(np.bincount(pair, minlength=count))[:-1]
    if count == 0:
        return np.zeros((0, 9, 9))
    return np.stack([block.T @ block for block in np.split(kron, bounds)])


def _cone_directions(axis: np.ndarray, half_angle: np.ndarray) -> np.ndarray:
    """(P, RING, 3) unit directions on the boundary of each pair's cone around its axis."""
    helper = np.where(np.abs(axis[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    side = np.cross(axis, helper)
    side /= np.linalg.norm(side, axis=1, keepdims=True)
    other = np.cross(axis, side)
    spin = np.linspace(0, 2 * np.pi, RING, endpoint=False)
    around = np.cos(spin)[None, :, None] * side[:, None] + np.sin(spin)[None, :, None] * other[:, None]
    return (np.cos(half_angle)[:, None, None] * axis[:, None]
            + np.sin(half_angle)[:, None, None] * around)


def smallest_eigen(symmetric: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Smallest eigenvalue (...) and unit eigenvector (..., 3) of symmetric 3x3 matrices, in
    closed form (Smith 1961): numpy's batched eigh is slow for many tiny matrices."""
    m = symmetric
    mean = np.trace(m, axis1=-2, axis2=-1) / 3
    shifted = m - mean[..., None, None] * np.eye(3)
    spread = np.sqrt(np.maximum((shifted**2).sum(axis=(-2, -1)) / 6, 1e-300))
    half_det = np.linalg.det(shifted / spread[..., None, None]) / 2
    phi = np.arccos(np.clip(half_det, -1.0, 1.0)) / 3
    value = mean + 2 * spread * np.cos(phi + 2 * np.pi / 3)
    rows = m - value[..., None, None] * np.eye(3)
    crosses = np.stack([np.cross(rows[..., 0, :], rows[..., 1, :]),
                        np.cross(rows[..., 0, :], rows[..., 2, :]),
                        np.cross(rows[..., 1, :], rows[..., 2, :])], axis=-2)
    norms = np.linalg.norm(crosses, axis=-1)
    best = np.take_along_axis(crosses, norms.argmax(axis=-1)[..., None, None], axis=-2)[..., 0, :]
    return value, best / np.maximum(norms.max(axis=-1), 1e-300)[..., None]


def cone_minimum(scatter: np.ndarray, baseline: np.ndarray, half_angle: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Smallest t^T S t over unit t within half_angle (rad) of +-baseline, per (P, K) matrix S
    (P, K, 3, 3), and the t (P, K, 3) that reaches it; baseline (P, 3), half_angle (P,)."""
    value, vector = smallest_eigen(scatter)
    inside = np.abs(np.einsum("pki,pi->pk", vector, baseline)) >= np.cos(half_angle)[:, None]
    ring = np.broadcast_to(_cone_directions(baseline, half_angle)[:, None],
                           (*scatter.shape[:2], RING, 3))
    ring_values = ((ring @ scatter) * ring).sum(axis=3)
    lowest = ring_values.argmin(axis=2)[..., None]
    on_ring = np.take_along_axis(ring_values, lowest, axis=2)[..., 0]
    ring_best = np.take_along_axis(ring, lowest[..., None], axis=2)[:, :, 0]
    axis = np.broadcast_to(baseline[:, None, None], (*scatter.shape[:2], 1, 3))
    on_axis = ((axis @ scatter) * axis).sum(axis=3)[..., 0]
    # the cone's best is its interior minimum when the free optimum lies inside, else on its rim
    rim = np.where((on_ring <= on_axis)[..., None], ring_best, axis[:, :, 0])
    best = np.where(inside, value, np.minimum(on_ring, on_axis))
    return best, np.where(inside[..., None], vector, rim)


def epipolar_rms(moments: np.ndarray, counts: np.ndarray, b_from_a: np.ndarray,
                 baseline: np.ndarray, half_angle: np.ndarray) -> np.ndarray:
    """(P, K) RMS algebraic epipolar residual (~ sine of a ray's angle to its epipolar plane) of
    each pair's matches under K rotations (P, K, 3, 3), each with its best unit translation within
    half_angle (rad) of the placed baseline direction (b's frame) or its opposite."""
    basis = (GENERATORS[None, None] @ b_from_a[:, :, None]).reshape(*b_from_a.shape[:2], 3, 9)
    value, _ = cone_minimum(basis @ (moments[:, None] @ np.swapaxes(basis, 2, 3)), baseline,
                            half_angle)
    return np.sqrt(np.maximum(value, 0.0) / counts[:, None])


def best_rms(moments: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """(P,) the lowest RMS residual any matrix reaches (8-point bound; |vec([t]x R)|^2 = 2)."""
    smallest = np.linalg.eigvalsh(moments)[:, 0]
    return np.sqrt(np.maximum(2.0 * smallest, 0.0) / counts)


def yaw_candidates(motions: Motions, rows: np.ndarray, span_deg: np.ndarray) -> np.ndarray:
    """(P, K, 3, 3) placed b_from_a with a's yaw turned across +-span about gravity."""
    steps = np.linspace(-1.0, 1.0, YAW_STEPS)
    turns = rotations_about(motions.up, np.radians(span_deg[:, None] * steps).ravel())
    turns = turns.reshape(len(rows), YAW_STEPS, 3, 3)
    cam_a, cam_b = motions.cam_rotations[rows[:, 0]], motions.cam_rotations[rows[:, 1]]
    return cam_b[:, None] @ turns @ np.swapaxes(cam_a, 1, 2)[:, None]


def baseline_cones(motions: Motions, rows: np.ndarray, tolerances: Tolerances
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Per pair: the placed baseline direction in b's frame, and how far (rad) it may be off.

    Each moved member may sit position_share of its range away from where the user put it.
    """
    centers = motions.centers
    offset = centers[rows[:, 0]] - centers[rows[:, 1]]  # t of b_from_a points from b towards a
    length = np.linalg.norm(offset, axis=1)
    in_b = np.einsum("pij,pj->pi", motions.cam_rotations[rows[:, 1]], offset)
    direction = in_b / np.maximum(length, 1e-12)[:, None]
    slack = tolerances.position_share * (motions.ranges[rows] * motions.moved[rows]).sum(axis=1)
    return direction, np.arctan2(slack, length)


def rotation_test(flat: FlatMatches, motions: Motions, evidence: Evidence,
                  tolerances: Tolerances, decided: np.ndarray | None = None) -> Verdicts:
    """Verdicts by the epipolar residual (deg) near the placed poses (the RMS, or the median
    where re-judged) per tested pair.

    Pairs marked `decided` (removed by another test) skip the costlier per-pair two-view check.
    """
    judged = (flat.inliers >= tolerances.rotation_min_inliers) & (flat.rows >= 0).all(axis=1)
    residual = np.full(len(flat.counts), np.nan)
    removed = np.zeros(len(flat.counts), dtype=bool)
    chosen = np.flatnonzero(judged)
    if len(chosen) == 0:
        return Verdicts(removed, judged, residual)
    keep = judged[flat.pair]
    pair = np.searchsorted(chosen, flat.pair[keep])
    rays = [evidence.rays[flat.keypoints[keep, side]] for side in (0, 1)]
    rows = flat.rows[chosen]
    span = yaw_slack_deg(tolerances.rotation_deg, tolerances.yaw_uncertainty_deg,
                         motions.moved_members(rows))
    candidates = yaw_candidates(motions, rows, span)
    cones = baseline_cones(motions, rows, tolerances)
    moments = epipolar_moments(rays[0], rays[1], pair, len(chosen))
    out, residual[chosen] = _epipolar_verdict(rays, pair, flat.counts[chosen], candidates, cones,
                                              tolerances, moments)
    model_rel = evidence.rotations[rows[:, 1]] @ np.swapaxes(evidence.rotations[rows[:, 0]], 1, 2)
    both = (motions.moved_members(rows) == 2) & (flat.inliers[chosen] >= BOTH_MOVED_MIN_INLIERS)
    both[both] = linear_disagreement(moments[both], candidates[both]) > tolerances.two_view_deg / 2
    check = ~out & (reoriented(model_rel, candidates, span) | both)
    if decided is not None:
        check &= ~decided[chosen]
    out |= _two_view_verdict(rays, pair, np.flatnonzero(check), candidates, cones, tolerances)
    removed[chosen] = out
    return Verdicts(removed, judged, residual)


def _two_view_verdict(rays, pair: np.ndarray, indices: np.ndarray, candidates: np.ndarray,
                      cones, tolerances: Tolerances) -> np.ndarray:
    """(P,) removed by the two-view stage, run on the pairs at `indices` one at a time."""
    out = np.zeros(len(candidates), dtype=bool)
    bounds = np.searchsorted(pair, np.arange(len(candidates) + 1))
    for index in indices:
        block = slice(bounds[index], bounds[index + 1])
        disagreement = two_view_disagreement(rays[0][block], rays[1][block], candidates[index],
                                             cones[0][index], cones[1][index])
        out[index] = disagreement > tolerances.two_view_deg
    return out


def _epipolar_verdict(rays, pair, counts, candidates, cones, tolerances: Tolerances,
                      moments: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(removed, residual deg): no rotation in the yaw range explains the matches (vectorised).

    The residual is the RMS under the best pose; where that is above the limit, the pair is
    judged again by its median match (robust_residual). A pair stays when the placed pose explains
    most of its matches, though a minority (look-alikes in a true pair, by design.md's definition
    up to half of them, or rays a slightly wrong model tilt leaves off) pushes the RMS past it.
    """
    rms = epipolar_rms(moments, counts, candidates, *cones)
    residual = np.degrees(np.arcsin(np.minimum(rms.min(axis=1), 1.0)))
    limit = np.degrees(np.minimum(np.maximum(
        np.radians(tolerances.epipolar_deg),
        tolerances.epipolar_ratio * best_rms(moments, counts)), np.pi / 2))
    again = np.flatnonzero(residual > limit)
    if len(again):
        keep = np.isin(pair, again)
        # strays raise every candidate's RMS, the right one's least: re-judge the lowest few
        likely = np.argsort(rms[again], axis=1)[:, :RECHECKED_CANDIDATES]
        residual[again] = robust_residual(
            [side[keep] for side in rays], np.searchsorted(again, pair[keep]),
            np.take_along_axis(candidates[again], likely[..., None, None], axis=1),
            [c[again] for c in cones])
    return residual > limit, residual


def robust_residual(rays, pair, candidates, cones) -> np.ndarray:
    """(P,) lowest median epipolar residual (deg) of each pair's matches over its candidate
    rotations (P, K, 3, 3), each with its translation refitted by IRLS: IRLS_STEPS refits with
    every match weighted 1 / max(its residual, IRLS_FLOOR_DEG). Pairs are contiguous in `pair`."""
    a, b = rays
    count = len(candidates)
    starts = np.searchsorted(pair, np.arange(count))
    # b . (t x R a) = t . ((R a) x b): linear in t, so a weighted 3x3 scatter per pair fits it
    normals = np.cross(np.einsum("nkij,nj->nki", candidates[pair], a), b[:, None])
    outer = (normals[..., :, None] * normals[..., None, :]).reshape(len(pair), -1, 9)
    weight = np.ones(normals.shape[:2])
    for _ in range(IRLS_STEPS + 1):
        scatter = np.add.reduceat(weight[..., None] * outer, starts).reshape(count, -1, 3, 3)
        _, translation = cone_minimum(scatter, *cones)
        sines = np.abs(np.einsum("nki,nki->nk", translation[pair], normals))
        degrees = np.degrees(np.arcsin(np.minimum(sines, 1.0)))
        weight = 1.0 / np.maximum(degrees, IRLS_FLOOR_DEG)
    medians = [segment_median(degrees[:, k], pair, count) for k in range(degrees.shape[1])]
    return np.min(medians, axis=0)


def linear_disagreement(moments: np.ndarray, candidates: np.ndarray) -> np.ndarray:
    """(P,) degrees between the nearest candidate (P, K, 3, 3) and either rotation of the pair's
    linear (8-point) essential matrix: a vectorised screen before the costlier two-view stage;
    a pair whose linear pose is near the placement is not checked further."""
    if len(moments) == 0:
        return np.zeros(0)
    _, vectors = np.linalg.eigh(moments)
    u, _, vt = np.linalg.svd(vectors[..., 0].reshape(-1, 3, 3))
    u = u * np.sign(np.linalg.det(u))[:, None, None]
    vt = vt * np.sign(np.linalg.det(vt))[:, None, None]
    turn = np.array([[0, -1.0, 0], [1, 0, 0], [0, 0, 1]])
    twisted = np.stack([u @ turn @ vt, u @ turn.T @ vt], axis=1)  # E = [t]x R has two R
    return rotation_angles_deg(twisted[:, :, None], candidates[:, None]).min(axis=(1, 2))


def reoriented(model_rel: np.ndarray, candidates: np.ndarray, span_deg: np.ndarray) -> np.ndarray:
    """Pairs whose placed relative rotation, yaw free within the span, is not the model's."""
    return rotation_angles_deg(model_rel[:, None], candidates).min(axis=1) > span_deg


def fit_homography(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, float]:
    """DLT homography b ~ H a of unit rays, scaled to middle singular value 1 and b . H a > 0,
    with its median transfer error (deg)."""
    outer = np.einsum("ni,nj->ij", a, a)
    moments = epipolar_moments(a, b, np.zeros(len(a), dtype=np.int64), 1)[0]
    # |b x H a|^2 = |H a|^2 - (b . H a)^2 for unit b: the same sums give the homography's moments
    _, vectors = np.linalg.eigh(np.kron(np.eye(3), outer) - moments)
    homography = vectors[:, 0].reshape(3, 3)
    homography /= np.linalg.svd(homography, compute_uv=False)[1]
    mapped = a @ homography.T
    if np.median(np.einsum("ni,ni->n", b, mapped)) < 0:
        homography, mapped = -homography, -mapped
    sine = np.linalg.norm(np.cross(b, mapped), axis=1) / np.linalg.norm(mapped, axis=1)
    return homography, float(np.degrees(np.arcsin(np.clip(np.median(sine), 0, 1))))


def _toward(axis: np.ndarray, direction: np.ndarray, half_angle: float) -> np.ndarray:
    """The unit vector within half_angle of +-axis closest to direction (K, 3)."""
    direction = direction * np.sign(direction @ axis)[:, None]
    cos = np.clip(direction @ axis, -1.0, 1.0)
    inside = cos >= np.cos(half_angle)
    side = direction - cos[:, None] * axis
    side /= np.maximum(np.linalg.norm(side, axis=1, keepdims=True), 1e-12)
    rim = np.cos(half_angle) * axis + np.sin(half_angle) * side
    return np.where(inside[:, None], direction, rim)


def plane_disagreement(homography: np.ndarray, candidates: np.ndarray, baseline: np.ndarray,
                       half_angle: float) -> float:
    """Degrees by which H = R + t n^T / d fails for the nearest candidate R with t in the cone.

    A plane's homography fits two poses; the placed translation tells them apart.
    """
    rest = homography[None] - candidates
    u, _, _ = np.linalg.svd(rest)
    t = _toward(baseline, u[:, :, 0], half_angle)
    off_t = rest - np.einsum("ki,kj,kjl->kil", t, t, rest)
    worst = np.linalg.svd(off_t, compute_uv=False)[:, 0].min()
    return float(np.degrees(2 * np.arcsin(min(worst / 2, 1.0))))


def two_view_disagreement(a: np.ndarray, b: np.ndarray, candidates: np.ndarray,
                          baseline: np.ndarray, half_angle: float) -> float:
    """Degrees between the pair's own relative pose and the nearest placed candidate; 0 when
    the pair cannot tell (too few RANSAC inliers)."""
    homography, transfer_deg = fit_homography(a, b)
    if transfer_deg <= HOMOGRAPHY_FIT_DEG:  # planar or a pure rotation
        return plane_disagreement(homography, candidates, baseline, half_angle)
    options = pycolmap.RANSACOptions()
    options.max_error, options.random_seed = RANSAC_MAX_ERROR, 0
    options.min_num_trials, options.max_num_trials = 30, 500
    found = pycolmap.estimate_relative_pose(a, b, options)
    if found is None or found["num_inliers"] < MIN_INLIER_SHARE * len(a):
        return 0.0
    return float(rotation_angles_deg(found["cam2_from_cam1"].rotation.matrix()[None], candidates).min())

