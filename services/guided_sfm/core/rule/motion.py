"""The user's placements as 3D motions: a moved camera's placement (a 2D pose on the ground plane)
implies a rigid motion of the model world, a turn about gravity (estimated from the model's cameras)
and a shift that keeps its height and tilt; with it, the placed cam_from_world of every model image
(its model pose moved by its motion, or left where it is)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from guided_sfm.core.geometry import (
    camera_centers,
    rotation_from_qvec,
    rotations_about,
    viewing_direction,
    yaw_in_frame,
)
from guided_sfm.core.rule.evidence import Evidence
from guided_sfm.core.types import CameraEdit, GroundFrame, SceneCamera, TopDownScene

# Weight of the frame's up against the cameras' own constraints (each normalised to trace 1).
GRAVITY_PRIOR = 0.05


@dataclass(frozen=True)
class Motions:
    """Per evidence row: the motion placed_from_model its placement implies (identity for a camera
    without one) and the placed cam_from_world."""

    motion_rotations: np.ndarray  # (I, 3, 3) placed_from_model
    motion_translations: np.ndarray  # (I, 3)
    cam_rotations: np.ndarray  # (I, 3, 3) placed cam_from_world
    cam_translations: np.ndarray  # (I, 3)
    moved: np.ndarray  # (I,) bool: the camera has a placement
    up: np.ndarray  # (3,) the gravity the motions turn about (model coordinates)
    ranges: np.ndarray  # (I,) each camera's frustum range (median point depth, model units)

    @property
    def centers(self) -> np.ndarray:
        """(I, 3) placed camera centres (model coordinates)."""
        return camera_centers(self.cam_rotations, self.cam_translations)

    def moved_members(self, rows: np.ndarray) -> np.ndarray:
        """(P,) how many members of each pair of evidence rows (P, 2) are moved."""
        return self.moved[rows].sum(axis=1)


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


def ground_motions(frame: GroundFrame, up: np.ndarray, model_centers: np.ndarray,
                   model_yaw_deg: np.ndarray, placed_xy_yaw: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
    """placed_from_model (rotations (N, 3, 3), translations (N, 3)) of placements in the frame.

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


def motions_of(scene: TopDownScene, placements: Mapping[int, CameraEdit],
               evidence: Evidence) -> Motions:
    """The motions of every evidence row: a moved camera carried to its placement, others kept."""
    count, up = len(evidence.rows), gravity(scene)
    motion_rotations, motion_translations = np.tile(np.eye(3), (count, 1, 1)), np.zeros((count, 3))
    cameras = {c.image_id: c for c in scene.cameras}
    rows, after = [], []
    for image_id, row in evidence.rows.items():
        placement = placements.get(image_id)
        if placement is not None and image_id in cameras:
            rows.append(row)
            after.append((placement.x, placement.y, placement.yaw_deg))
    if rows:
        centers = camera_centers(evidence.rotations[rows], evidence.translations[rows])
        motion_rotations[rows], motion_translations[rows] = ground_motions(
            scene.frame, up, centers, _model_yaws(scene.frame, cameras, evidence, rows),
            np.array(after))
    # cam_from_placed = cam_from_model . model_from_placed
    rotations = evidence.rotations @ motion_rotations.transpose(0, 2, 1)
    translations = evidence.translations - np.einsum("nij,nj->ni", rotations, motion_translations)
    moved = np.zeros(count, dtype=bool)
    moved[rows] = True
    return Motions(motion_rotations, motion_translations, rotations, translations, moved, up,
                   _ranges(cameras, evidence))


def _model_yaws(frame: GroundFrame, cameras: Mapping[int, SceneCamera], evidence: Evidence,
                rows: list[int]) -> np.ndarray:
    """Each row's yaw (deg, frame) at its evidence pose: the scene's for an image of the largest
    model, from the evidence rotation for one a placed sub-model lends (rule.evidence.gather
    carries it into the largest model's world; the scene has no pose for it)."""
    image_of = {row: image_id for image_id, row in evidence.rows.items()}
    yaws = [cameras[image_of[row]].yaw_deg for row in rows]
    return np.array([float(yaw_in_frame(viewing_direction(evidence.rotations[row]), frame))
                     if yaw is None else yaw for row, yaw in zip(rows, yaws, strict=True)])


def _ranges(cameras: Mapping[int, SceneCamera], evidence: Evidence) -> np.ndarray:
    """Each row's frustum range; the median of the others where the scene has none."""
    ranges = np.array([getattr(cameras.get(i), "range", None) or np.nan for i in evidence.rows])
    known = ranges[np.isfinite(ranges)]
    return np.where(np.isfinite(ranges), ranges, np.median(known) if len(known) else 1.0)

