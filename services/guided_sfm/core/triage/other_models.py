"""Where the cameras of a model other than the largest probably belong. Nothing in the matches
links such a model to the largest (that is why COLMAP split them), but the capture does: its
first camera follows its capture neighbour in the largest model, perhaps after a few cameras in
no model. The model (its group poses, design.md v1.1: its own relative poses, scaled to the
largest model's step) is moved rigidly so that the capture walks across each gap the way it
moves at the gap's two edges; the cameras in no model inside the gap are laid along that walk.
Where both models' walls show a clear direction (walls.py), the walk's turn is corrected so the
model's walls run the way the largest model's do."""

from __future__ import annotations

import numpy as np

from guided_sfm.core.triage import poses2d, walls
from guided_sfm.core.triage.pieces import GROUP, LOOSE, Piece


def _edge_motion(poses: np.ndarray) -> np.ndarray | None:
    """The motion of the first step of poses (N, 3), in its first camera's frame; None for one
    pose. A hand-held walk turns on the spot at a corner, so the step nearest the gap is the
    best guess of how the capture moved inside it."""
    if len(poses) < 2:
        return None
    motion = poses2d.between(poses[0], poses[1])
    motion[2] = np.angle(np.exp(1j * motion[2]))
    return motion


def bridge(before: np.ndarray, after: np.ndarray, gap: int, step: float,
           extra_turn: float = 0.0) -> np.ndarray:
    """The poses (gap + 1, 3) of the `gap` cameras missing between poses `before` and `after`
    (capture order; after in a frame of its own) and of after's first camera: a walk on from
    before's last pose at the mean of its last step and after's first step, turning by
    extra_turn (radians) more in all, spread evenly over its steps."""
    motions = [m for m in (_edge_motion(before[-2:]), _edge_motion(after[:2]))
               if m is not None]
    if motions:
        xy = np.mean([m[:2] for m in motions], axis=0)
        turn = float(np.angle(np.mean(np.exp(1j * np.array([m[2] for m in motions])))))
        motion = np.array([*xy, turn])
    else:
        motion = np.array([step, 0.0, 0.0])
    motion = motion + np.array([0.0, 0.0, extra_turn / (gap + 1)])
    trail, pose = [], before[-1]
    for _ in range(gap + 1):
        pose = poses2d.compose(pose, motion)
        trail.append(pose)
    return np.array(trail)


def _trusted_side(pieces: list[Piece], trusted: list[bool], index: int,
                  side: int) -> tuple[int, list[int]] | None:
    """(the trusted piece next to piece index on one side, the loose pieces between), or None
    when the next piece with poses on that side is not trusted."""
    between, j = [], index + side
    while 0 <= j < len(pieces) and pieces[j].kind == LOOSE:
        between.append(j)
        j += side
    if 0 <= j < len(pieces) and trusted[j]:
        return j, between
    return None


# The walls correct the walk's turn by at most this much: a walk across a gap of a few turn
# views was measured 1.5-4.5 deg off on split (26 deg where the largest model's own turn view
# is 7 deg off, seed 2); the walls' directions repeat every 90 deg, so a larger correction
# could be the wrong wall.
MAX_WALL_TURN_DEG = 30.0


def place_other_models(pieces: list[Piece], poses: list, trusted: list[bool], step: float,
                       ground_points: dict[int, np.ndarray] | None = None) -> None:
    """Move each other model's pieces (in poses) by the one rigid motion that continues the
    capture from their trusted neighbours on either side; lay the loose pieces between along.
    ground_points: per model, its 3D points on the ground plane where its cameras are (the
    largest model's as placed, another's at its group poses), for the walls' direction."""
    ground_points = ground_points or {}
    reference = walls.wall_direction(ground_points.get(0, np.zeros((0, 2))), step)
    for model in sorted({p.cameras[0].model for p in pieces if p.kind == GROUP}):
        walked = _across_gaps(pieces, poses, trusted, model, step)
        if walked is None:
            continue
        motion = _fit(*walked[:2], step)
        own = walls.wall_direction(ground_points.get(model, np.zeros((0, 2))), step)
        if reference is not None and own is not None:
            turn = walls.turn_onto(own + motion[2], reference)
            if np.degrees(abs(turn)) <= MAX_WALL_TURN_DEG:
                walked = _across_gaps(pieces, poses, trusted, model, step, turn)
                motion = _fit(*walked[:2], step)
        for i, piece in enumerate(pieces):
            if piece.kind == GROUP and piece.cameras[0].model == model:
                poses[i] = poses2d.apply(motion, piece.poses)
        for k, placed in walked[2].items():
            poses[k] = placed


def _across_gaps(pieces: list[Piece], poses: list, trusted: list[bool], model: int, step: float,
                 extra_turn: float = 0.0) -> tuple[np.ndarray, np.ndarray, dict] | None:
    """(the model's edge poses, where the walks across its gaps put them, the loose pieces laid
    along those walks), each walk turning by extra_turn more; None without a trusted side."""
    source, target, laid = [], [], {}
    for i, piece in enumerate(pieces):
        if piece.kind != GROUP or piece.cameras[0].model != model:
            continue
        for side in (-1, 1):
            found = _trusted_side(pieces, trusted, i, side)
            if found is None:
                continue
            j, between = found
            near, own = (poses[j], piece.poses) if side < 0 else (poses[j][::-1], piece.poses[::-1])
            trail = bridge(near, own, sum(len(pieces[k].cameras) for k in between), step, extra_turn)
            source.append(own[0])
            target.append(trail[-1])
            for k in reversed(between):  # the trail starts at the trusted piece
                count = len(pieces[k].cameras)
                laid[k] = trail[:count] if side < 0 else trail[:count][::-1]
                trail = trail[count:]
    return (np.array(source), np.array(target), laid) if source else None


def _fit(source: np.ndarray, target: np.ndarray, step: float) -> np.ndarray:
    """The rigid motion taking source poses onto target poses (exactly for one pose)."""
    if len(source) == 1:
        return poses2d.compose(target[0], poses2d.inverse(source[0]))
    return poses2d.fit_rigid(source, target, 2 * step)
