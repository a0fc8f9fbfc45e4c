"""Split models on the top-down view: the cameras of a model other than the largest keep their
own model's relative poses, brought into the scene's 2D frame by a proposed similarity (up to
the scene's up, scaled to the largest model's camera spacing) and set down beside the largest
model, so the editor can move the whole sub-model as one piece (design.md v1.1 `group_pose`)."""

from __future__ import annotations

import numpy as np

from guided_sfm.core import geometry
from guided_sfm.core.colmap_model import ModelPose
from guided_sfm.core.types import GroundFrame

# The gap left between the largest model's cameras and a sub-model set down beside them, as a
# share of the largest model's extent.
GAP_SHARE = 0.15


def _turn_onto(source: np.ndarray, target: np.ndarray) -> np.ndarray:
    """The smallest rotation taking unit vector source onto unit vector target."""
    axis = np.cross(source, target)
    sin, cos = np.linalg.norm(axis), float(source @ target)
    if sin < 1e-9:
        return np.eye(3) if cos > 0 else geometry.rotations_about(_any_normal(source), np.array([np.pi]))[0]
    return geometry.rotations_about(axis / sin, np.array([np.arctan2(sin, cos)]))[0]


def _any_normal(vector: np.ndarray) -> np.ndarray:
    helper = np.eye(3)[int(np.argmin(np.abs(vector)))]
    return np.cross(vector, helper)


def spacing(centers: np.ndarray) -> float:
    """Median distance between consecutive (capture-order) camera centres; 0 with fewer than two."""
    steps = np.linalg.norm(np.diff(centers, axis=0), axis=1)
    steps = steps[steps > 0]
    return float(np.median(steps)) if len(steps) else 0.0


def group_poses(model: dict[int, ModelPose], order: list[int], frame: GroundFrame,
                largest_xy: np.ndarray, largest_spacing: float) -> dict[int, dict[str, float]]:
    """{image_id: {x, y, yaw_deg}} of one sub-model's cameras (their model poses, order =
    capture order of its image ids) placed beside the largest model's 2D cameras."""
    ids = [i for i in order if i in model]
    if not ids:
        return {}
    centers = np.array([model[i].center for i in ids])
    turn = _up_turn(model, ids, frame)
    own = spacing(centers)
    scale = largest_spacing / own if own > 0 and largest_spacing > 0 else 1.0
    xy = frame.to_2d((centers - centers.mean(axis=0)) @ turn.T * scale + frame.origin)
    yaws = [geometry.yaw_in_frame(turn @ geometry.viewing_direction(model[i].rotation), frame)
            for i in ids]
    xy = xy + _beside(xy, largest_xy)
    return {i: {"x": float(p[0]), "y": float(p[1]), "yaw_deg": float(y)}
            for i, p, y in zip(ids, xy, yaws, strict=True)}


def _up_turn(model: dict[int, ModelPose], ids: list[int], frame: GroundFrame) -> np.ndarray:
    """The rotation taking the cameras' mean up onto the scene's up."""
    ups = np.array([geometry.camera_up(model[i].rotation) for i in ids])
    up = ups.mean(axis=0) / (np.linalg.norm(ups.mean(axis=0)) or 1.0)
    return _turn_onto(up, frame.up)


def points_at_group_poses(model: dict[int, ModelPose], placed: dict[int, tuple[float, float]],
                          frame: GroundFrame, points: np.ndarray) -> np.ndarray:
    """(N, 2) the sub-model's 3D points (N, 3) in the scene's 2D frame, carried like its cameras
    (placed: {image_id: (x, y)} of its group poses): their walls say how it is turned."""
    ids = [i for i in placed if i in model]
    if not ids or not len(points):
        return np.zeros((0, 2))
    turn = _up_turn(model, ids, frame)
    own = frame.to_2d(np.array([model[i].center for i in ids]) @ turn.T)
    target = np.array([placed[i] for i in ids], dtype=float)
    # the group poses are the turned centres scaled and shifted: recover both from them
    own_centred, target_centred = own - own.mean(axis=0), target - target.mean(axis=0)
    spread = float((own_centred**2).sum())
    scale = float((own_centred * target_centred).sum()) / spread if spread > 0 else 1.0
    return scale * (frame.to_2d(np.asarray(points) @ turn.T) - own.mean(axis=0)) + target.mean(axis=0)


def upright_points(model: dict[int, ModelPose], frame: GroundFrame, points: np.ndarray) -> np.ndarray:
    """(N, 2) the model's 3D points (N, 3) seen from above along its cameras' mean up, then
    carried into the scene's 2D frame as directions are: where the frame's fitted ground is
    tilted (a model that sees one wall only: 22-30 deg on split seeds 1, 2, 7) the walls seen
    along the frame's up are wide bands, seen along the cameras' up they are lines."""
    ids = list(model)
    if not ids or not len(points):
        return np.zeros((0, 2))
    turn = _up_turn(model, ids, frame)
    axes = np.stack([frame.x_axis, frame.y_axis], axis=1)  # (3, 2)
    upright = frame.to_2d(np.asarray(points) @ turn.T)
    return upright @ (axes.T @ turn.T @ axes).T  # each upright direction as the frame shows it


def _beside(xy: np.ndarray, largest_xy: np.ndarray) -> np.ndarray:
    """The shift that sets the group's box to the right of the largest model's, centred on it."""
    if not len(largest_xy):
        return np.zeros(2)
    lo, hi = largest_xy.min(axis=0), largest_xy.max(axis=0)
    gap = GAP_SHARE * max(float((hi - lo).max()), 1e-9)
    return np.array([hi[0] + gap - xy[:, 0].min(), (lo[1] + hi[1]) / 2 - xy[:, 1].mean()])
