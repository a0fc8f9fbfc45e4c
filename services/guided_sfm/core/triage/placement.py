"""Where each piece of the capture probably belongs: the largest continuous piece is the anchor;
walking out from it in capture order, each next piece is expected to continue the trajectory of
the piece placed before it (same step and turn). A piece already there is trusted; any other is
moved rigidly (its own relative poses kept, they are usually right) onto the continuation, from
both sides where both neighbours are trusted, or by the symmetry its look-alike matches with the
pieces placed before it imply (symmetry.py), where that symmetry stands out."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from guided_sfm.core.triage import other_models, poses2d, symmetry
from guided_sfm.core.triage.pieces import LOOSE, PLACED, Piece
from guided_sfm.core.triage.signals import BREAK_STEPS, turn_deg

# A piece whose end lands within these of the continuation of its placed neighbour is trusted.
TRUST_TURN_DEG = 45.0
CONTINUE_FROM = 4  # steps of the placed neighbour a continuation follows


@dataclass
class Placement:
    """Per piece: its 2D poses where it probably belongs, and whether it was already there."""

    poses: list[np.ndarray | None]
    trusted: list[bool]
    anchor: int
    by_symmetry: list[bool] = field(default_factory=list)
    by_hop: list[bool] = field(default_factory=list)  # follows its capture neighbour's hop


def anchor_of(pieces: list[Piece]) -> int | None:
    """The largest piece of the largest model (the first of equals), or None."""
    sizes = [len(p.cameras) if p.kind == PLACED else -1 for p in pieces]
    return int(np.argmax(sizes)) if sizes and max(sizes) > 0 else None


def _ahead(poses: np.ndarray, step: float) -> np.ndarray:
    """The pose after the last of poses, walking on at the mean step length, heading and turn
    of the last few (hand-held yaw sways from shot to shot; the mean does not); a single pose:
    one typical step straight ahead."""
    if len(poses) < 2:
        return poses2d.compose(poses[-1], np.array([step, 0.0, 0.0]))
    recent = np.asarray(poses)[-(CONTINUE_FROM + 1):]
    k = len(recent) - 1
    moves = np.diff(recent[:, :2], axis=0)
    yaws = np.unwrap(recent[:, 2])
    rate = float(np.mean(np.diff(yaws)))  # turn per step
    headings = np.unwrap(np.arctan2(moves[:, 1], moves[:, 0]))
    heading = float(np.mean(headings)) + rate * (k + 1) / 2
    length = float(np.mean(np.linalg.norm(moves, axis=1)))
    yaw = float(np.mean(yaws)) + rate * (k / 2 + 1)
    return np.array([*(recent[-1, :2] + length * np.array([np.cos(heading), np.sin(heading)])), yaw])


def _reverse(poses: np.ndarray) -> np.ndarray:
    return np.asarray(poses)[::-1]


def _agrees(expected: np.ndarray, actual: np.ndarray, step: float) -> bool:
    close = np.hypot(*(expected[:2] - actual[:2])) < BREAK_STEPS * step
    return bool(close and turn_deg(np.degrees(expected[2]), np.degrees(actual[2])) < TRUST_TURN_DEG)


def _place_after(piece: Piece, before: np.ndarray, step: float) -> tuple[np.ndarray, bool]:
    """(poses, trusted) of a piece that follows poses `before` in capture order."""
    expected = _ahead(before, step)
    if piece.kind == LOOSE:  # no poses of its own: keep walking at the last step and turn
        trail = [*before[-2:], expected]
        for _ in piece.cameras[1:]:
            trail.append(_ahead(np.array(trail[-2:]), step))
        return np.array(trail[-len(piece.cameras):]), False
    conflict = piece.break_before is not None and piece.break_before.conflict
    if piece.kind == PLACED and not conflict and _agrees(expected, piece.poses[0], step):
        return piece.poses, True
    motion = poses2d.fit_rigid(piece.poses[:1], expected[None], 2 * step)
    return poses2d.apply(motion, piece.poses), False


def _flipped(piece: Piece) -> Piece:
    """The piece walked backwards (its breaks swapped), to place it before its successor."""
    poses = None if piece.poses is None else _reverse(piece.poses)
    return Piece(piece.kind, piece.cameras[::-1], poses, piece.break_after, piece.break_before)


def place_pieces(pieces: list[Piece], step: float, anchors: list = (),
                 split_points: dict | None = None, hops: dict | None = None,
                 ground_points: dict | None = None) -> Placement | None:
    """Where every piece probably belongs, walking out from the anchor both ways; a moved piece
    whose look-alike matches with the pieces placed before it imply a clear symmetry is moved by
    it; one that follows a capture neighbour's hop across its break (two_view.hops_of) is put
    there; one whose pairs to trusted cameras say where it is (two_view.Anchor) is fitted to
    them; another model's pieces continue the capture across the gap, turned so its walls run
    the way the largest model's do (other_models.py, ground_points: per model, its points on the
    ground plane)."""
    anchor = anchor_of(pieces)
    if anchor is None:
        return None
    poses: list[np.ndarray | None] = [None] * len(pieces)
    trusted, by_symmetry = [False] * len(pieces), [False] * len(pieces)
    poses[anchor], trusted[anchor] = pieces[anchor].poses, True
    walk = _Walk(pieces, poses, split_points or {}, step)
    walk.placed(anchor)
    for i in range(anchor + 1, len(pieces)):
        poses[i], trusted[i] = _place_after(pieces[i], poses[i - 1], step)
        by_symmetry[i] = not trusted[i] and walk.by_symmetry(i)
        walk.placed(i)
    for i in range(anchor - 1, -1, -1):
        placed, trusted[i] = _place_after(_flipped(pieces[i]), _reverse(poses[i + 1]), step)
        poses[i] = _reverse(placed)
        by_symmetry[i] = not trusted[i] and walk.by_symmetry(i)
        walk.placed(i)
    sure = [t or s for t, s in zip(trusted, by_symmetry, strict=True)]
    between = _between_trusted(pieces, poses, sure, step)
    by_hop = _follow_hops(pieces, poses, anchor, [s or b for s, b in zip(sure, between, strict=True)],
                          hops or {}, step)
    other_models.place_other_models(pieces, poses, sure, step, ground_points)
    # two-view anchors are seen from the anchor camera's model pose: only trusted pieces give
    # them, and a piece the symmetry or a hop moved keeps that move
    _to_anchors(pieces, poses, trusted, anchors, step,
                [s or h for s, h in zip(by_symmetry, by_hop, strict=True)])
    return Placement(poses, trusted, anchor, by_symmetry, by_hop)


# A point pair agrees with a motion when it carries the run's point within this many typical
# steps of the placed one (measured on twins seed 0: 0.1, 0.25 and 0.5 each recover the main
# run's move 0.08-0.12 steps off; 0.25 is the middle of that range).
SYMMETRY_TOLERANCE_STEPS = 0.25


class _Walk:
    """The pieces placed so far, walking out from the anchor, and the motion each was moved
    by: a run's look-alike matches with them say where it goes (symmetry.py)."""

    def __init__(self, pieces: list[Piece], poses: list, split_points: dict, step: float):
        self.pieces, self.poses, self.split_points, self.step = pieces, poses, split_points, step
        self.motions: dict[int, np.ndarray] = {}  # image id -> motion of its placed piece

    def placed(self, index: int) -> None:
        piece = self.pieces[index]
        if piece.kind != PLACED:
            return
        motion = poses2d.fit_rigid(piece.poses, self.poses[index], 2 * self.step)
        self.motions.update({c.image_id: motion for c in piece.cameras})

    def by_symmetry(self, index: int) -> bool:
        """Move the piece by the symmetry its split points with placed pieces imply, when one
        stands out and more of its pairs agree with it than with the continuation."""
        piece = self.pieces[index]
        if piece.kind != PLACED:
            return False
        moving, fixed = symmetry.thinned(*self._pairs(set(piece.image_ids)))  # both counts among these
        tolerance = SYMMETRY_TOLERANCE_STEPS * self.step
        found = symmetry.symmetry_of(moving, fixed, tolerance)
        if found is None:
            return False
        continued = poses2d.fit_rigid(piece.poses, self.poses[index], 2 * self.step)
        if found.support <= symmetry.agreeing(continued, moving, fixed, tolerance).sum():
            return False
        self.poses[index] = poses2d.apply(found.motion, piece.poses)
        return True

    def _pairs(self, own: set[int]) -> tuple[np.ndarray, np.ndarray]:
        """(run's points, placed pieces' points where they were moved) of split points."""
        moving, fixed = [np.zeros((0, 2))], [np.zeros((0, 2))]
        for (a, b), (points_a, points_b) in self.split_points.items():
            if a in own and b in self.motions:
                moving.append(points_a)
                fixed.append(symmetry.apply(self.motions[b], points_b))
            elif b in own and a in self.motions:
                moving.append(points_b)
                fixed.append(symmetry.apply(self.motions[a], points_a))
        return np.vstack(moving), np.vstack(fixed)


def _between_trusted(pieces: list[Piece], poses: list, trusted: list[bool],
                     step: float) -> list[bool]:
    """Refit each moved piece that lies between two trusted ones to continue both; which were."""
    refitted = [False] * len(pieces)
    for i in range(1, len(pieces) - 1):
        piece = pieces[i]
        if trusted[i] or piece.kind == LOOSE or not (trusted[i - 1] and trusted[i + 1]):
            continue
        refitted[i] = True
        from_before = _ahead(poses[i - 1], step)
        from_after = _ahead(_reverse(poses[i + 1]), step)  # a motion walked backwards
        source = np.array([piece.poses[0], piece.poses[-1]])
        motion = poses2d.fit_rigid(source, np.array([from_before, from_after]), 2 * step)
        poses[i] = poses2d.apply(motion, piece.poses)
    return refitted


def _follow_hops(pieces: list[Piece], poses: list, anchor: int, settled: list[bool], hops: dict,
                 step: float) -> list[bool]:
    """Walking out from the anchor, put each moved piece where the matches of the capture
    neighbours across its break put it, seen from the neighbour as placed (two_view.hops_of):
    a capture can jump where no trajectory continues (twins walks from one box round to the far
    side of the other). Pieces already settled (trusted, moved by a symmetry, or fitted between
    two trusted ones) stay. Which pieces were moved."""
    moved = [False] * len(pieces)
    walk = [(i, i - 1, -1, 0) for i in range(anchor + 1, len(pieces))] + \
           [(i, i + 1, 0, -1) for i in range(anchor - 1, -1, -1)]
    for i, neighbour, start, end in walk:
        if settled[i] or pieces[i].kind != PLACED:
            continue
        hop = hops.get((pieces[neighbour].cameras[start].image_id, pieces[i].cameras[end].image_id))
        if hop is None or poses[neighbour] is None:
            continue
        target = poses2d.compose(poses[neighbour][start], hop)
        motion = poses2d.fit_rigid(pieces[i].poses[end:][:1], target[None], 2 * step)
        poses[i], moved[i] = poses2d.apply(motion, pieces[i].poses), True
    return moved


# A piece is fitted to its two-view anchors when at least this many agree, from directions this
# far apart, on a yaw within this spread; a ray may miss the fitted camera by this many steps.
MIN_ANCHORS, MIN_RAY_SPREAD_DEG, MAX_YAW_SPREAD_DEG, MAX_MISS_STEPS = 3, 10.0, 20.0, 1.0


def _to_anchors(pieces: list[Piece], poses: list, trusted: list[bool], anchors: list,
                step: float, keep: list[bool]) -> None:
    """Refit each moved piece to where its pairs with trusted cameras put it."""
    known = {c.image_id: p for i, piece in enumerate(pieces) if trusted[i]
             for c, p in zip(piece.cameras, piece.poses, strict=True)}
    for i, piece in enumerate(pieces):
        if trusted[i] or keep[i] or piece.kind == LOOSE:
            continue
        own = {c.image_id: p for c, p in zip(piece.cameras, piece.poses, strict=True)}
        mine = [a for a in anchors if a.image_id in own and a.anchor in known]
        motion = fit_to_anchors(own, known, mine, step)
        if motion is not None:
            poses[i] = poses2d.apply(motion, piece.poses)


def fit_to_anchors(own: dict[int, np.ndarray], known: dict[int, np.ndarray], anchors: list,
                   step: float) -> np.ndarray | None:
    """The rigid motion (as a pose applied on the left) that turns the piece's own poses to the
    anchors' yaws and puts each camera on its anchor's ray; None when they do not agree."""
    if len(anchors) < MIN_ANCHORS:
        return None
    turns = np.array([np.radians(a.yaw_deg) - own[a.image_id][2] for a in anchors])
    angle = float(np.angle(np.mean(np.exp(1j * turns))))
    if np.degrees(np.abs(np.angle(np.exp(1j * (turns - angle))))).max() > MAX_YAW_SPREAD_DEG:
        return None
    rays = np.array([a.ray_rad for a in anchors])
    if np.degrees(np.ptp(np.unwrap(rays))) < MIN_RAY_SPREAD_DEG:
        return None
    turn = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    turned = np.array([turn @ own[a.image_id][:2] for a in anchors])
    origins = np.array([known[a.anchor][:2] for a in anchors])
    normals = np.stack([-np.sin(rays), np.cos(rays)], axis=1)
    shift = np.linalg.lstsq(normals, np.einsum("ij,ij->i", normals, origins - turned), rcond=None)[0]
    ahead = np.einsum("ij,ij->i", turned + shift - origins, np.stack([np.cos(rays), np.sin(rays)], 1))
    misses = np.abs(np.einsum("ij,ij->i", normals, turned + shift - origins))
    if misses.max() > MAX_MISS_STEPS * step or (ahead < 0).mean() > 0.5:
        return None
    return np.array([shift[0], shift[1], angle])
