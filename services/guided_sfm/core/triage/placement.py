"""Where each piece of the capture probably belongs: the largest continuous piece is the anchor;
walking out from it in capture order, each next piece is expected to continue the trajectory of
the piece placed before it (same step and turn). A piece already there is trusted; any other is
moved rigidly (its own relative poses kept, they are usually right) onto the continuation, from
both sides where both neighbours are trusted."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from guided_sfm.core.triage import poses2d
from guided_sfm.core.triage.pieces import LOOSE, PLACED, Piece
from guided_sfm.core.triage.signals import BREAK_STEPS, turn_deg

# A piece whose end lands within these of the continuation of its placed neighbour is trusted.
TRUST_TURN_DEG = 45.0


@dataclass
class Placement:
    """Per piece: its 2D poses where it probably belongs, and whether it was already there."""

    poses: list[np.ndarray | None]
    trusted: list[bool]
    anchor: int


def anchor_of(pieces: list[Piece]) -> int | None:
    """The largest piece of the largest model (the first of equals), or None."""
    sizes = [len(p.cameras) if p.kind == PLACED else -1 for p in pieces]
    return int(np.argmax(sizes)) if sizes and max(sizes) > 0 else None


def _ahead(poses: np.ndarray, step: float) -> np.ndarray:
    """The pose after the last of poses at the motion between its last two (a single pose:
    one typical step straight ahead)."""
    if len(poses) >= 2:
        return poses2d.continue_forward(poses[-2], poses[-1])
    return poses2d.compose(poses[-1], np.array([step, 0.0, 0.0]))


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


def place_pieces(pieces: list[Piece], step: float) -> Placement | None:
    """Where every piece probably belongs, walking out from the anchor both ways."""
    anchor = anchor_of(pieces)
    if anchor is None:
        return None
    poses: list[np.ndarray | None] = [None] * len(pieces)
    trusted = [False] * len(pieces)
    poses[anchor], trusted[anchor] = pieces[anchor].poses, True
    for i in range(anchor + 1, len(pieces)):
        poses[i], trusted[i] = _place_after(pieces[i], poses[i - 1], step)
    for i in range(anchor - 1, -1, -1):
        placed, trusted[i] = _place_after(_flipped(pieces[i]), _reverse(poses[i + 1]), step)
        poses[i] = _reverse(placed)
    _between_trusted(pieces, poses, trusted, step)
    return Placement(poses, trusted, anchor)


def _between_trusted(pieces: list[Piece], poses: list, trusted: list[bool], step: float) -> None:
    """Refit each moved piece that lies between two trusted ones to continue both."""
    for i in range(1, len(pieces) - 1):
        piece = pieces[i]
        if trusted[i] or piece.kind == LOOSE or not (trusted[i - 1] and trusted[i + 1]):
            continue
        from_before = _ahead(poses[i - 1], step)
        from_after = _ahead(_reverse(poses[i + 1]), step)  # a motion walked backwards
        source = np.array([piece.poses[0], piece.poses[-1]])
        motion = poses2d.fit_rigid(source, np.array([from_before, from_after]), 2 * step)
        poses[i] = poses2d.apply(motion, piece.poses)
