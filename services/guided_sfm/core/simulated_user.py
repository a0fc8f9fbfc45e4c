"""A simulated user for the headless loop: places cameras near their true poses, with noise."""

from __future__ import annotations

import numpy as np

from guided_sfm.core.geometry import viewing_direction, yaw_in_frame
from guided_sfm.core.metrics import Similarity
from guided_sfm.core.truth import Truth
from guided_sfm.core.types import CameraEdit, TopDownScene

OFFSET_M = 0.3  # how far from the truth the simulated user drops a camera (metres)
YAW_NOISE_DEG = 10.0  # and how far off its heading


def place_cameras(scene: TopDownScene, truth: Truth, names: list[str],
                  truth_from_model: Similarity, seed: int = 0,
                  offset_m: float = OFFSET_M, yaw_noise_deg: float = YAW_NOISE_DEG
                  ) -> list[CameraEdit]:
    """Edits that put each named camera at its true 2D pose plus a fixed-size random error."""
    rng = np.random.default_rng(seed)
    by_name = {c.name: c for c in scene.cameras}
    rotation = np.asarray(truth_from_model.rotation)
    edits = []
    for name in sorted(names):
        true = truth.cameras[name]
        center = rotation.T @ (true.center - truth_from_model.translation) / truth_from_model.scale
        direction = rotation.T @ viewing_direction(true.rotation)
        xy = scene.frame.to_2d(center[None])[0]
        angle = rng.uniform(0, 2 * np.pi)
        xy = xy + offset_m / truth_from_model.scale * np.array([np.cos(angle), np.sin(angle)])
        yaw = float(yaw_in_frame(direction, scene.frame)) + rng.choice([-1, 1]) * yaw_noise_deg
        edits.append(CameraEdit(by_name[name].image_id, float(xy[0]), float(xy[1]), yaw))
    return edits


def _model_ground(scene: TopDownScene, truth: Truth, names: list[str],
                  truth_from_model: Similarity) -> np.ndarray:
    """(N, 2) true centres of the named cameras in the scene's frame (the truth carried into
    the model by the inverse of truth_from_model)."""
    rotation = np.asarray(truth_from_model.rotation)
    centers = np.array([rotation.T @ (truth.cameras[n].center - truth_from_model.translation)
                        / truth_from_model.scale for n in names])
    return scene.frame.to_2d(centers)


def _circle(xy: np.ndarray) -> tuple[np.ndarray, float]:
    """Least-squares circle (centre, radius) through 2D points (Kasa's fit)."""
    system = np.column_stack([2 * xy, np.ones(len(xy))])
    solution = np.linalg.lstsq(system, (xy**2).sum(axis=1), rcond=None)[0]
    center = solution[:2]
    return center, float(np.sqrt(solution[2] + center @ center))


def place_on_circle(scene: TopDownScene, truth: Truth, names: list[str],
                    truth_from_model: Similarity, seed: int = 0,
                    offset_m: float = OFFSET_M, yaw_noise_deg: float = YAW_NOISE_DEG
                    ) -> list[CameraEdit]:
    """A capture-shape user on an orbit: every named camera re-laid on one circle, evenly spaced
    in capture order (file-name order) from the first view's angle to the last's, facing the
    circle's centre, then dropped with the same random error as place_cameras. The user knows
    the capture went round the object in order, not where each photo was taken."""
    rng = np.random.default_rng(seed)
    ordered = sorted(names)
    by_name = {c.name: c for c in scene.cameras}
    xy = _model_ground(scene, truth, ordered, truth_from_model)
    center, radius = _circle(xy)
    angles = np.unwrap(np.arctan2(xy[:, 1] - center[1], xy[:, 0] - center[0]))
    even = np.linspace(angles[0], angles[-1], len(ordered))
    edits = []
    for name, angle in zip(ordered, even, strict=True):
        spot = center + radius * np.array([np.cos(angle), np.sin(angle)])
        spot = spot + offset_m / truth_from_model.scale * _unit(rng.uniform(0, 2 * np.pi))
        yaw = np.degrees(angle + np.pi) + rng.choice([-1, 1]) * yaw_noise_deg
        edits.append(CameraEdit(by_name[name].image_id, float(spot[0]), float(spot[1]),
                                float((yaw + 180) % 360 - 180)))
    return edits


def _unit(angle: float) -> np.ndarray:
    return np.array([np.cos(angle), np.sin(angle)])


# The editor's rotation keys (frontend/js/editor.js): q/r turn by 2 deg, 10 deg with shift.
KEY_TURN_DEG, SHIFT_KEY_TURN_DEG = 2.0, 10.0


def key_presses_to_turn(degrees: float) -> int:
    """Rotation key presses to turn a camera by degrees: big (shift) steps, then small ones."""
    turn = abs((degrees + 180.0) % 360.0 - 180.0)
    big = int(turn // SHIFT_KEY_TURN_DEG)
    return big + int(round((turn - big * SHIFT_KEY_TURN_DEG) / KEY_TURN_DEG))


def hand_actions(scene: TopDownScene, placed: list[CameraEdit]) -> dict[str, int]:
    """What a user does by hand to make these placements: one drag per camera and the rotation
    keys from the yaw it is shown at (its model yaw; a camera in no model starts at 0 deg)."""
    keys = 0
    for edit in placed:
        shown = scene.camera(edit.image_id)
        start = shown.yaw_deg if shown is not None and shown.yaw_deg is not None else 0.0
        keys += key_presses_to_turn(edit.yaw_deg - start)
    return {"drags": len(placed), "key_presses": keys, "accepts": 0}


def accepts(runs: int) -> dict[str, int]:
    """A user who accepts proposed runs: one click per run, nothing dragged or turned."""
    return {"drags": 0, "key_presses": 0, "accepts": runs}


def _true_pose_2d(scene: TopDownScene, truth: Truth, name: str,
                  truth_from_model: Similarity) -> tuple[float, float, float]:
    """(x, y, yaw_deg) of a camera's true pose in the scene's frame."""
    rotation = np.asarray(truth_from_model.rotation)
    xy = _model_ground(scene, truth, [name], truth_from_model)[0]
    yaw = yaw_in_frame(rotation.T @ viewing_direction(truth.cameras[name].rotation), scene.frame)
    return float(xy[0]), float(xy[1]), float(yaw)


def move_groups(scene: TopDownScene, truth: Truth, truth_from_model: Similarity
                ) -> tuple[list[CameraEdit], dict[str, int]]:
    """A user who drags each split-off model (its cameras at their group_pose) as one piece
    onto where it belongs and turns it there: one drag and the rotation keys per group. The
    piece keeps its own shape (the best rigid fit of its group poses to the truth)."""
    from guided_sfm.core.triage import poses2d  # the editor's group move is a rigid 2D motion

    groups: dict[int, list] = {}
    for camera in scene.cameras:
        if camera.group_pose is not None and camera.name in truth.cameras:
            groups.setdefault(camera.model, []).append(camera)
    edits, keys = [], 0
    for cameras in groups.values():
        source = np.array([poses2d.pose(**c.group_pose) for c in cameras])
        target = np.array([poses2d.pose(*_true_pose_2d(scene, truth, c.name, truth_from_model))
                           for c in cameras])
        motion = poses2d.fit_rigid(source, target, float(np.ptp(target[:, :2], axis=0).max()))
        keys += key_presses_to_turn(float(np.degrees(motion[2])))
        for camera, pose in zip(cameras, poses2d.apply(motion, source), strict=True):
            edits.append(CameraEdit(camera.image_id, float(pose[0]), float(pose[1]),
                                    float((np.degrees(pose[2]) + 180.0) % 360.0 - 180.0)))
    return edits, {"drags": len(groups), "key_presses": keys, "accepts": 0}
