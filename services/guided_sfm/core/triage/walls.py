"""The room's walls as a compass: a model's 3D points, seen from above, lie along its walls, and
the walls of one room run in shared directions (modulo 90 deg in a rectangular room). Two models
that no verified pair links still see the same room, so the direction of their walls says how
one is turned against the other far more precisely than a walk across the gap between them
(other_models.py), whose turn comes from a few turn views with few points."""

from __future__ import annotations

import numpy as np

QUARTER = np.pi / 2
# Directions are scored every COARSE_DEG, then refined every FINE_DEG around the best.
COARSE_DEG, FINE_DEG = 0.5, 0.05
# A wall's offsets are counted in bins of this many typical camera steps: thin enough that a
# wall seen from above is one or two bins wide, wide enough for the points' noise.
BIN_STEPS = 0.1
# A direction is the walls' when its score is this many times the median direction's (walls
# measured 10-64x on the split layout; a blob of points scores every direction alike) and no
# other direction, 5 deg or more away, scores over SECOND_SHARE of it.
MIN_PEAK_RATIO, SECOND_SHARE, SECOND_APART_DEG = 4.0, 0.5, 5.0
MIN_POINTS = 50
MAX_POINTS = 5000  # every k-th point beyond this: the direction needs no more, big models stay fast


def _concentration(xy: np.ndarray, angles: np.ndarray, bin_size: float) -> np.ndarray:
    """Per direction: how tightly the points' offsets across it bunch (the sum of squared bin
    counts, over N^2): points along a line of that direction fall into one bin."""
    scores = np.empty(len(angles))
    for k, angle in enumerate(angles):
        offsets = xy @ np.array([-np.sin(angle), np.cos(angle)])
        counts = np.bincount(((offsets - offsets.min()) / bin_size).astype(np.int64))
        scores[k] = float((counts.astype(float) ** 2).sum())
    return scores / len(xy) ** 2


def _without_strays(xy: np.ndarray) -> np.ndarray:
    """The points inside the box of their 1st-99th percentiles grown by half its size: a point
    triangulated far off (near-parallel rays) would stretch the offsets' bins without end."""
    lo, hi = np.percentile(xy, [1, 99], axis=0)
    margin = 0.5 * (hi - lo)
    return xy[np.all((xy >= lo - margin) & (xy <= hi + margin), axis=1)]


def _manhattan(xy: np.ndarray, angles: np.ndarray, bin_size: float) -> np.ndarray:
    """Scores of directions modulo 90 deg: a wall and the walls square to it count together."""
    return _concentration(xy, angles, bin_size) + _concentration(xy, angles + QUARTER, bin_size)


def wall_direction(xy: np.ndarray, step: float) -> float | None:
    """The direction (radians in [0, pi/2), modulo 90 deg) the points (N, 2) line up along
    most, or None when no direction stands out (too few points, a blob, or two directions
    alike: a room that is not rectangular)."""
    xy = np.asarray(xy, dtype=float).reshape(-1, 2)
    if len(xy) < MIN_POINTS or step <= 0:
        return None
    xy = _without_strays(xy[::-(-len(xy) // MAX_POINTS)])
    bin_size = BIN_STEPS * step
    coarse = np.radians(np.arange(0.0, 90.0, COARSE_DEG))
    scores = _manhattan(xy, coarse, bin_size)
    best = int(np.argmax(scores))
    if scores[best] < MIN_PEAK_RATIO * float(np.median(scores)):
        return None
    apart = np.degrees(np.abs(np.angle(np.exp(4j * (coarse - coarse[best]))))) / 4  # modulo 90
    if scores[apart >= SECOND_APART_DEG].max(initial=0.0) > SECOND_SHARE * scores[best]:
        return None
    fine = coarse[best] + np.radians(np.arange(-COARSE_DEG, COARSE_DEG + FINE_DEG / 2, FINE_DEG))
    return float(fine[int(np.argmax(_manhattan(xy, fine, bin_size)))] % QUARTER)


def turn_onto(own: float, reference: float) -> float:
    """The smallest turn (radians, within +-45 deg) that carries wall direction own onto
    reference modulo 90 deg."""
    return float(np.angle(np.exp(4j * (reference - own))) / 4)
