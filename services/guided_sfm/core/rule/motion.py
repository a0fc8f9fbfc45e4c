"""A user's placement as 3D motions: each moved camera's 2D move on the ground plane becomes a turn
about gravity (estimated from the model's cameras) and a shift that keeps its height and tilt; and
the placed cam_from_world of every model image."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from guided_sfm.core.geometry import camera_centers, rotation_from_qvec, rotations_about
from guided_sfm.core.rule.evidence import Evidence
from guided_sfm.core.types import CameraEdit, GroundFrame, SceneCamera, TopDownScene

# Weight of the frame's up against the cameras' own constraints (each normalised to trace 1).
GRAVITY_PRIOR = 0.05


@dataclass(frozen=True)
class Placement:
    """Per evidence row: the rigid move placed_from_model and the placed cam_from_world."""

    move_rotations: np.ndarray  # (I, 3, 3), identity for cameras left where they were
    move_translations: np.ndarray  # (I, 3)
    rotations: np.ndarray  # (I, 3, 3) placed cam_from_world
    translations: np.ndarray  # (I, 3)
    moved: np.ndarray  # (I,) bool
    up: np.ndarray  # (3,) the gravity the moves turned about (model coordinates)
    ranges: np.ndarray  # (I,) each camera's frustum range (median point depth, model units)

    @property
    def centers(self) -> np.ndarray:
        """(I, 3) placed camera centres (model coordinates)."""
        return camera_centers(self.rotations, self.translations)


def gravity(scene: TopDownScene) -> np.ndarray:
    """Unit up direction (model coordinates) from the registered cameras, the frame's up as prior.

    Hand-held cameras keep their x axis level and their centres near one height, so up is the
    direction those leave free; where they leave more than one free (a straight walk), the frame's
    up fills in. The fitted ground plane alone can tilt tens of degrees when the floor is sparse.
    """
    placed = [c for c in scene.cameras if c.center is not None and c.qvec is not None]
    prior = np.asarray(scene.frame.up, dtype=float)
    if len(placed) < 3:
        return prior
    rights = np.array([rotation_from_qvec(c.qvec)[0] for c in placed])
    centers = np.array([c.center for c in placed])
    spread = np.cov(centers.T)
    constraints = rights.T @ rights / len(rights) + spread / max(np.trace(spread), 1e-12)
    up = np.linalg.solve(constraints + GRAVITY_PRIOR * np.eye(3), prior)
    return up / np.linalg.norm(up)


def ground_moves(frame: GroundFrame, up: np.ndarray, model_centers: np.ndarray,
                 model_yaw_deg: np.ndarray, placed_xy_yaw: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    """placed_from_model (rotations (N, 3, 3), translations (N, 3)) of 2D moves in the frame.

    Each camera turns about `up` through its own centre and shifts by the frame's 2D offset, its
    height along `up` kept.
    """
    placed_xy_yaw = np.atleast_2d(placed_xy_yaw)
    rotations = rotations_about(up, np.radians(placed_xy_yaw[:, 2] - model_yaw_deg))
    offset = placed_xy_yaw[:, :2] - frame.to_2d(model_centers)
    # the frame's normal may differ from up: climb along it just enough to keep the height
    climb = -(offset @ np.stack([frame.x_axis @ up, frame.y_axis @ up])) / (frame.up @ up)
    shift = offset @ np.stack([frame.x_axis, frame.y_axis]) + climb[:, None] * frame.up
    turned = np.einsum("nij,nj->ni", rotations, model_centers)
    return rotations, model_centers + shift - turned


def place(scene: TopDownScene, moved: Mapping[int, CameraEdit], evidence: Evidence) -> Placement:
    """The placement of every evidence row: moved cameras carried by their 2D move, others kept."""
    count, up = len(evidence.rows), gravity(scene)
    move_rotations, move_translations = np.tile(np.eye(3), (count, 1, 1)), np.zeros((count, 3))
    cameras = {c.image_id: c for c in scene.cameras}
    rows, yaws, after = [], [], []
    for image_id, row in evidence.rows.items():
        edit, camera = moved.get(image_id), cameras.get(image_id)
        if edit is not None and camera is not None and camera.yaw_deg is not None:
            rows.append(row)
            yaws.append(camera.yaw_deg)
            after.append((edit.x, edit.y, edit.yaw_deg))
    if rows:
        centers = camera_centers(evidence.rotations[rows], evidence.translations[rows])
        move_rotations[rows], move_translations[rows] = ground_moves(
            scene.frame, up, centers, np.array(yaws), np.array(after))
    # cam_from_placed = cam_from_model . model_from_placed
    rotations = evidence.rotations @ move_rotations.transpose(0, 2, 1)
    translations = evidence.translations - np.einsum("nij,nj->ni", rotations, move_translations)
    flags = np.zeros(count, dtype=bool)
    flags[rows] = True
    return Placement(move_rotations, move_translations, rotations, translations, flags, up,
                     _ranges(cameras, evidence))


def _ranges(cameras: Mapping[int, SceneCamera], evidence: Evidence) -> np.ndarray:
    """Each row's frustum range; the median of the others where the scene has none."""
    ranges = np.array([getattr(cameras.get(i), "range", None) or np.nan for i in evidence.rows])
    known = ranges[np.isfinite(ranges)]
    return np.where(np.isfinite(ranges), ranges, np.median(known) if len(known) else 1.0)

