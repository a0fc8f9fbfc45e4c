"""The signals triage reads, each on plain values: capture-order continuity (steps and turns
between capture neighbours against the capture's typical step), the match graph (pairs whose 3D
overlap in the model is small for their inlier count) and missing correspondences."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from guided_sfm.core.triage.evidence import MissingCount
from guided_sfm.core.types import PairKey, SceneCamera, pair_key

# A capture-order step this many typical steps long breaks the capture's continuity when it also
# turns this sharply (hand-held walks sway by 20 deg a step) or its pair shares under half the
# capture's typical share of 3D points; a long step alone does not (people walk unevenly: on Lund
# the last photos are 5-10 typical steps apart).
BREAK_STEPS, TURN_BREAK_DEG, TURN_BREAK_STEPS = 3.0, 60.0, 2.0
# A pair is in conflict with the model when it has this many inliers and the model gives both
# images fewer than this share of the capture's typical share of its inliers as common 3D points
# (true matches the model cannot hold). The typical share is the median over capture neighbours:
# ~0.9 on renderings, ~0.3 on real photographs whose matches are not all triangulated.
CONFLICT_MIN_INLIERS, CONFLICT_SHARE, WEAK_SHARE = 30, 0.25, 0.5
# The missing-correspondence cue counts only with this many points expected in view.
MISSING_MIN_EXPECTED = 30


@dataclass(frozen=True)
class Step:
    """From one registered camera to the next in capture order (both in the largest model)."""

    before: SceneCamera
    after: SceneCamera
    length_steps: float  # in typical steps
    turn_deg: float
    inliers: int  # of their verified pair, 0 if none
    shared_points: int
    typical_share: float = 1.0  # the capture's median share of inliers held as 3D points

    @property
    def conflict(self) -> bool:
        return is_conflict(self.inliers, self.shared_points, self.typical_share)

    @property
    def breaks(self) -> bool:
        """True when the two are not placed like neighbours of one continuous capture."""
        if self.length_steps < TURN_BREAK_STEPS:
            return False
        if self.conflict:
            return True
        weak = self.shared_points < WEAK_SHARE * self.typical_share * max(self.inliers, 1)
        sharp = self.turn_deg >= TURN_BREAK_DEG
        return self.length_steps >= BREAK_STEPS and (weak or sharp)


def is_conflict(inliers: int, shared_points: int, typical_share: float = 1.0) -> bool:
    """Many verified matches, but the model shares next to none of them as 3D points."""
    return (inliers >= CONFLICT_MIN_INLIERS
            and shared_points < CONFLICT_SHARE * typical_share * inliers)


def typical_share(cameras: list[SceneCamera], pairs: dict[PairKey, int],
                  shared_points: dict[PairKey, int]) -> float:
    """Median share of a capture-neighbour pair's inliers that the model holds as 3D points."""
    placed = [c for c in cameras if c.registered]
    shares = [shared_points.get(k, 0) / pairs[k] for k in
              (pair_key(a.image_id, b.image_id) for a, b in zip(placed[:-1], placed[1:], strict=True))
              if pairs.get(k, 0) >= CONFLICT_MIN_INLIERS]
    return float(np.clip(np.median(shares), 0.05, 1.0)) if shares else 1.0


def typical_step_of(cameras: list[SceneCamera]) -> float:
    """Median 2D distance between consecutive registered cameras (1 if there are none)."""
    xy = np.array([(c.x, c.y) for c in cameras if c.registered]).reshape(-1, 2)
    steps = np.linalg.norm(np.diff(xy, axis=0), axis=1)
    steps = steps[steps > 0]
    return float(np.median(steps)) if len(steps) else 1.0


def turn_deg(yaw_a: float, yaw_b: float) -> float:
    """Unsigned difference of two yaws (deg) in [0, 180]."""
    return float(abs((yaw_b - yaw_a + 180.0) % 360.0 - 180.0))


def steps_between(cameras: list[SceneCamera], pairs: dict[PairKey, int],
                  shared_points: dict[PairKey, int]) -> list[Step]:
    """Every step between capture neighbours that are both registered, in capture order."""
    placed = [c for c in cameras if c.registered]
    step = typical_step_of(placed)
    share = typical_share(placed, pairs, shared_points)
    out = []
    for a, b in zip(placed[:-1], placed[1:], strict=True):
        key = pair_key(a.image_id, b.image_id)
        out.append(Step(a, b, float(np.hypot(b.x - a.x, b.y - a.y)) / step,
                        turn_deg(a.yaw_deg, b.yaw_deg), pairs.get(key, 0),
                        shared_points.get(key, 0), share))
    return out


def conflicts_by_image(pairs: dict[PairKey, int], shared_points: dict[PairKey, int],
                       share: float = 1.0) -> dict[int, list[tuple[PairKey, int, int]]]:
    """Per image: (pair, inliers, shared points) of its pairs in conflict with the model, against
    the capture's typical share (one pass over the pairs)."""
    out: dict[int, list[tuple[PairKey, int, int]]] = {}
    for key, n in pairs.items():
        if key in shared_points and is_conflict(n, shared_points[key], share):
            for image_id in key:
                out.setdefault(image_id, []).append((key, n, shared_points[key]))
    return out


def missing_share(count: MissingCount | None) -> float | None:
    """Share of the points expected in view that the camera did not match; None when too few
    points were expected to judge."""
    if count is None or count.expected < MISSING_MIN_EXPECTED:
        return None
    return 1.0 - count.matched / count.expected


def closes_loop(cameras: list[SceneCamera], pairs: dict[PairKey, int],
                shared_points: dict[PairKey, int]) -> bool:
    """True when the capture ends where it began (an orbit): its last and first registered
    cameras are placed like capture neighbours and matched consistently."""
    placed = [c for c in cameras if c.registered]
    if len(placed) < 3:
        return False
    first, last = placed[0], placed[-1]
    key = pair_key(first.image_id, last.image_id)
    closing = Step(last, first, float(np.hypot(first.x - last.x, first.y - last.y))
                   / typical_step_of(placed), turn_deg(last.yaw_deg, first.yaw_deg),
                   pairs.get(key, 0), shared_points.get(key, 0),
                   typical_share(placed, pairs, shared_points))
    return (closing.inliers >= CONFLICT_MIN_INLIERS and not closing.breaks
            and _same_heading(placed[-2], last, first))


def _same_heading(a: SceneCamera, b: SceneCamera, c: SceneCamera) -> bool:
    """True when b -> c moves the way a -> b did, seen from each step's start camera (within
    45 deg): a loop's seam continues the walk, it does not step back."""
    def heading(start: SceneCamera, end: SceneCamera) -> float:
        return np.degrees(np.arctan2(end.y - start.y, end.x - start.x)) - start.yaw_deg

    return turn_deg(heading(a, b), heading(b, c)) < 45.0


def loop_start(cameras: list[SceneCamera], steps: list[Step]) -> int:
    """Where to start walking a closed loop: right after its first break (0 without one)."""
    for step in steps:
        if step.breaks:
            return next(i for i, c in enumerate(cameras) if c.image_id == step.after.image_id)
    return 0
