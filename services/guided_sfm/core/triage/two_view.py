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

from guided_sfm.core import colmap_db, geometry, model_files
from guided_sfm.core.colmap_model import ModelPose, model_poses
from guided_sfm.core.triage.evidence import ModelReads
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


# A hop's baseline is scaled by at least this many of its inliers that the start camera holds as
# 3D points, agreeing within this share of their median (else the pair gives no hop).
MIN_SCALE_POINTS, MAX_SCALE_SPREAD = 10, 0.25


def _ground_pose(rotation: np.ndarray, center: np.ndarray, frame: GroundFrame) -> np.ndarray:
    """(x, y, yaw rad) in the frame of a camera (cam_from_world rotation, world centre)."""
    x, y = frame.to_2d(center[None])[0]
    return np.array([x, y, np.radians(float(geometry.yaw_in_frame(
        geometry.viewing_direction(rotation), frame)))])


def _baseline(b_from_a: np.ndarray, t: np.ndarray, points_a: np.ndarray,
              rays_b: np.ndarray) -> float | None:
    """The length s of t (unit) that makes b_from_a @ X + s t project onto rays_b (N, 3) for the
    points X (N, 3) in a's camera frame: per point least squares, their median when they agree."""
    rotated = points_a @ b_from_a.T
    across_t, across_x = np.cross(rays_b, t), np.cross(rays_b, rotated)
    norm = np.einsum("ij,ij->i", across_t, across_t)
    usable = norm > 1e-12
    if usable.sum() < MIN_SCALE_POINTS:
        return None
    each = -np.einsum("ij,ij->i", across_t, across_x)[usable] / norm[usable]
    scale = float(np.median(each))
    if scale <= 0 or np.median(np.abs(each - scale)) > MAX_SCALE_SPREAD * scale:
        return None
    return scale


def hops_of(database: Path, model: pycolmap.Reconstruction, reads: ModelReads, frame: GroundFrame,
            pairs: Iterable[PairKey]) -> dict[tuple[int, int], np.ndarray]:
    """(start, to) -> where the pair's own matches put camera `to` in start's ground frame, as a
    2D pose (poses2d.between of the two): the relative pose of the matches alone, its baseline
    scaled by the 3D points the model holds for start's keypoints (a camera's own points are
    right relative to it even where its piece is misplaced). Both directions of every listed pair
    of registered images that gives one."""
    poses = model_poses(model)
    wanted = [p for p in pairs if p[0] in poses and p[1] in poses]
    if not wanted:
        return {}
    observations, (ids, xyz) = reads.observations, reads.points
    out = {}
    for (i, j), rows in colmap_db.inlier_matches_of(database, wanted).items():
        # a model may hold fewer 2D points than the database has keypoints (known poses only)
        rows = rows[(rows[:, 0] < len(observations[i][0])) & (rows[:, 1] < len(observations[j][0]))]
        if len(rows) < MIN_MATCHES:
            continue
        rows = rows[np.linspace(0, len(rows) - 1, min(len(rows), MAX_MATCHES)).astype(int)]
        cameras = {k: model.cameras[model.image(k).camera_id] for k in (i, j)}
        xy = {i: observations[i][0][rows[:, 0]], j: observations[j][0][rows[:, 1]]}
        point_ids = {i: observations[i][1][rows[:, 0]], j: observations[j][1][rows[:, 1]]}
        found = _relative(cameras[i], xy[i], cameras[j], xy[j])
        if found is None:
            continue
        j_from_i, t = found
        for start, to, to_from_start, t_start in ((i, j, j_from_i, t),
                                                 (j, i, j_from_i.T, -j_from_i.T @ t)):
            hop = _hop(poses[start], cameras[to], xy[to], point_ids[start], ids, xyz,
                       to_from_start, t_start / np.linalg.norm(t_start), frame)
            if hop is not None:
                out[(start, to)] = hop
    return out


def _hop(start: ModelPose, camera_to: pycolmap.Camera, xy_to: np.ndarray, point_ids: np.ndarray,
         ids: np.ndarray, xyz: np.ndarray, to_from_start: np.ndarray, t: np.ndarray,
         frame: GroundFrame) -> np.ndarray | None:
    held = point_ids != model_files.NO_POINT
    if held.sum() < MIN_SCALE_POINTS:
        return None
    points = model_files.points_of(point_ids[held], ids, xyz) @ start.rotation.T + start.translation
    rays = np.hstack([camera_to.cam_from_img(xy_to[held]), np.ones((int(held.sum()), 1))])
    scale = _baseline(to_from_start, t, points, rays)
    if scale is None:
        return None
    rotation = to_from_start @ start.rotation  # `to`'s cam_from_world
    center = start.center + start.rotation.T @ (-to_from_start.T @ (scale * t))
    a = _ground_pose(start.rotation, start.center, frame)
    b = _ground_pose(rotation, center, frame)
    turn = np.array([[np.cos(a[2]), np.sin(a[2])], [-np.sin(a[2]), np.cos(a[2])]])
    return np.array([*(turn @ (b[:2] - a[:2])), b[2] - a[2]])
