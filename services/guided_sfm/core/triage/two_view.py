"""Where a pair's own matches put one camera relative to the other: for pairs the model cannot
hold (true matches across a fold), the relative pose estimated from their matches alone gives,
from a trusted camera's model pose, the other camera's yaw and the ground direction it lies in.
A run's proposal is fitted to these where they agree (placement.fit_to_anchors)."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pycolmap

from guided_sfm.core import colmap_db, geometry
from guided_sfm.core.colmap_model import ModelPose, model_poses
from guided_sfm.core.types import GroundFrame, PairKey

MIN_MATCHES, MIN_INLIER_SHARE = 30, 0.5
MAX_MATCHES = 500  # evenly thinned beyond this: a relative pose needs far fewer


@dataclass(frozen=True)
class Anchor:
    """From camera `anchor` at its model pose, the pair's own geometry puts camera `image_id`
    at this yaw (deg) and in this ground direction (rad) from the anchor."""

    image_id: int
    anchor: int
    yaw_deg: float
    ray_rad: float


def _relative(camera_a: pycolmap.Camera, xy_a: np.ndarray, camera_b: pycolmap.Camera,
              xy_b: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """(R, t) of cam_b_from_cam_a estimated from the matches alone, or None."""
    options = pycolmap.RANSACOptions()
    options.max_error, options.random_seed = 2.0, 0
    # a fold's true matches are mostly inliers: a thousand trials find them (the default
    # 10,000 made triage take 30 s on twins)
    options.min_num_trials, options.max_num_trials = 100, 1000
    found = pycolmap.estimate_relative_pose(camera_a, xy_a, camera_b, xy_b, options)
    if found is None or found["num_inliers"] < MIN_INLIER_SHARE * len(xy_a):
        return None
    pose = found["cam2_from_cam1"]
    return pose.rotation.matrix(), np.asarray(pose.translation, dtype=float)


def _anchor(image_id: int, anchor: int, anchor_pose: ModelPose, b_from_a: np.ndarray,
            b_in_a: np.ndarray, frame: GroundFrame) -> Anchor:
    """image_id seen from anchor: b_from_a rotates anchor's camera frame into image_id's,
    b_in_a is image_id's centre direction in anchor's camera frame."""
    rotation = b_from_a @ anchor_pose.rotation  # image_id's cam_from_world
    yaw = float(geometry.yaw_in_frame(geometry.viewing_direction(rotation), frame))
    direction = anchor_pose.rotation.T @ b_in_a
    return Anchor(image_id, anchor, yaw, float(np.arctan2(direction @ frame.y_axis,
                                                          direction @ frame.x_axis)))


def anchors_of(database: Path, model: pycolmap.Reconstruction, frame: GroundFrame,
               pairs: Iterable[PairKey]) -> list[Anchor]:
    """Both directions of every listed pair of registered images whose own relative pose could
    be estimated."""
    poses = model_poses(model)
    wanted = [p for p in pairs if p[0] in poses and p[1] in poses]
    matches = colmap_db.inlier_matches_of(database, wanted)
    keypoints: dict[int, np.ndarray] = {}
    out = []
    for (i, j), rows in matches.items():
        if len(rows) < MIN_MATCHES:
            continue
        rows = rows[np.linspace(0, len(rows) - 1, min(len(rows), MAX_MATCHES)).astype(int)]
        for k in (i, j):
            keypoints.setdefault(k, colmap_db.keypoints(database, k))
        found = _relative(model.cameras[model.image(i).camera_id], keypoints[i][rows[:, 0]],
                          model.cameras[model.image(j).camera_id], keypoints[j][rows[:, 1]])
        if found is None:
            continue
        j_from_i, t = found
        out.append(_anchor(j, i, poses[i], j_from_i, -j_from_i.T @ t, frame))
        out.append(_anchor(i, j, poses[j], j_from_i.T, t, frame))
    return out
