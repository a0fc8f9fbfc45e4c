"""The symmetry a run's look-alike matches imply: where the model holds the two keypoints of a
verified match as two different 3D points (one seen by a camera of the run, one by a camera of a
piece placed before it, trusted or moved), the ground-plane motion that carries the run's points
onto the placed ones is where the run belongs, when one motion stands out. A scene of repeated
structures admits several such motions (each look-alike maps onto each); only the true matches
single one out."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# A symmetry counts when this many point pairs agree on it and this many times as many as on the
# best motion of the pairs left over. Measured with bench_triage (2026-12-03): the runs whose true
# move it found stood out 4.2x (twins seed 7), 5.2x (seed 0) and 9.9x (seed 11), office's 29x and
# 51x; runs of twins with no true match to the placed cameras had look-alike motions at 3.1x
# (seed 7) and 2.8x (seed 11), every other run at most 2.7x (orbit's). The margin is thin: see
# docs/triage.md, "Limits".
MIN_SUPPORT, DISTINCT = 30, 4.0
TRIALS = 400  # 2-point samples; at a tenth of pairs agreeing, 400 draw some 4 good ones
MAX_PAIRS = 3000  # evenly thinned beyond this (the fit needs far fewer; keeps triage fast)


@dataclass(frozen=True)
class Symmetry:
    """motion: (x, y, angle rad) of a pose applied on the left (poses2d.apply), taking the
    moving points onto the fixed ones; support: pairs within the tolerance; runner_up: pairs
    of the best motion among the rest."""

    motion: np.ndarray
    support: int
    runner_up: int


def _rotation(angle):
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s], [s, c]])


def apply(motion: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(N, 2) points moved by motion (x, y, angle)."""
    return np.asarray(points, float) @ _rotation(motion[2]).T + motion[:2]


def fit(moving: np.ndarray, fixed: np.ndarray) -> np.ndarray:
    """Least-squares rigid motion (x, y, angle) with motion(moving) ~ fixed (2D Procrustes)."""
    moving_mean, fixed_mean = moving.mean(0), fixed.mean(0)
    cov = (fixed - fixed_mean).T @ (moving - moving_mean)
    angle = np.arctan2(cov[1, 0] - cov[0, 1], cov[0, 0] + cov[1, 1])
    shift = fixed_mean - _rotation(angle) @ moving_mean
    return np.array([shift[0], shift[1], angle])


def agreeing(motion: np.ndarray, moving: np.ndarray, fixed: np.ndarray,
             tolerance: float) -> np.ndarray:
    """Mask of the pairs that motion carries within tolerance of each other."""
    return np.linalg.norm(apply(motion, moving) - fixed, axis=1) < tolerance


def _strongest(moving: np.ndarray, fixed: np.ndarray, tolerance: float,
               rng: np.random.Generator) -> tuple[np.ndarray | None, np.ndarray]:
    """(motion, mask of its pairs) of the motion most pairs agree on (RANSAC on 2-point
    samples, refitted once on its pairs), or (None, no pairs)."""
    count = len(moving)
    none = np.zeros(count, bool)
    if count < 2:
        return None, none
    first, second = rng.integers(0, count, TRIALS), rng.integers(0, count, TRIALS)
    spread = np.linalg.norm(moving[first] - moving[second], axis=1)
    keep = (first != second) & (spread > 2 * tolerance)  # two near points fix no angle
    first, second = first[keep], second[keep]
    if not len(first):
        return None, none
    # angle of each sample: the turn from the moving segment to the fixed one
    d_moving, d_fixed = moving[second] - moving[first], fixed[second] - fixed[first]
    angles = (np.arctan2(d_fixed[:, 1], d_fixed[:, 0]) - np.arctan2(d_moving[:, 1], d_moving[:, 0]))
    cos, sin = np.cos(angles), np.sin(angles)
    mid_moving, mid_fixed = (moving[first] + moving[second]) / 2, (fixed[first] + fixed[second]) / 2
    shift = mid_fixed - np.stack([cos * mid_moving[:, 0] - sin * mid_moving[:, 1],
                                  sin * mid_moving[:, 0] + cos * mid_moving[:, 1]], 1)
    x = cos[:, None] * moving[None, :, 0] - sin[:, None] * moving[None, :, 1] + shift[:, :1]
    y = sin[:, None] * moving[None, :, 0] + cos[:, None] * moving[None, :, 1] + shift[:, 1:]
    counts = (np.hypot(x - fixed[None, :, 0], y - fixed[None, :, 1]) < tolerance).sum(1)
    best = int(np.argmax(counts))
    if counts[best] < 2:
        return None, none
    mask = np.hypot(x[best] - fixed[:, 0], y[best] - fixed[:, 1]) < tolerance
    motion = fit(moving[mask], fixed[mask])
    refitted = agreeing(motion, moving, fixed, tolerance)
    if refitted.sum() < mask.sum():
        return np.array([shift[best, 0], shift[best, 1], angles[best]]), mask
    return motion, refitted


def thinned(moving: np.ndarray, fixed: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The (N, 2) pairs evenly thinned to MAX_PAIRS: the pairs symmetry_of counts its support
    among (compare another motion's count on these too)."""
    moving, fixed = np.asarray(moving, float).reshape(-1, 2), np.asarray(fixed, float).reshape(-1, 2)
    if len(moving) > MAX_PAIRS:
        rows = np.linspace(0, len(moving) - 1, MAX_PAIRS).astype(int)
        moving, fixed = moving[rows], fixed[rows]
    return moving, fixed


def symmetry_of(moving: np.ndarray, fixed: np.ndarray, tolerance: float,
                seed: int = 0) -> Symmetry | None:
    """The rigid ground-plane motion T with T(moving[k]) ~ fixed[k] for the most pairs k, when
    at least MIN_SUPPORT pairs agree within tolerance and DISTINCT times as many as on the best
    motion of the pairs left over; else None. moving, fixed: (N, 2)."""
    moving, fixed = thinned(moving, fixed)
    if len(moving) < MIN_SUPPORT:
        return None
    rng = np.random.default_rng(seed)
    motion, mask = _strongest(moving, fixed, tolerance, rng)
    if motion is None or mask.sum() < MIN_SUPPORT:
        return None
    _, other = _strongest(moving[~mask], fixed[~mask], tolerance, rng)
    support, runner_up = int(mask.sum()), int(other.sum())
    if support < DISTINCT * runner_up:
        return None
    return Symmetry(motion, support, runner_up)
