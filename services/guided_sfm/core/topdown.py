"""The top-down scene (design.md step 3) built from pycolmap reconstructions."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pycolmap

from guided_sfm.core import geometry
from guided_sfm.core.errors import EmptyModel
from guided_sfm.core.ground_plane import ground_frame
from guided_sfm.core.types import GroundFrame, SceneCamera, TopDownScene


@dataclass(frozen=True)
class ModelPose:
    """A registered image's pose: cam_from_world rotation/translation, centre (model coords)."""

    rotation: np.ndarray
    translation: np.ndarray
    center: np.ndarray
    qvec: np.ndarray  # (w, x, y, z), world-to-camera


def model_poses(reconstruction: pycolmap.Reconstruction) -> dict[int, ModelPose]:
    """Pose of every registered image of a model, by COLMAP image id."""
    poses = {}
    for image_id, image in reconstruction.images.items():
        if not image.has_pose:
            continue
        cam_from_world = image.cam_from_world()
        rotation = cam_from_world.rotation.matrix()
        translation = np.asarray(cam_from_world.translation, dtype=float)
        poses[image_id] = ModelPose(rotation, translation,
                                    geometry.camera_centers(rotation, translation),
                                    geometry.qvec_from_pycolmap(cam_from_world.rotation.quat))
    return poses


def point_array(reconstruction: pycolmap.Reconstruction) -> tuple[np.ndarray, np.ndarray]:
    """(ids sorted, (N, 3) xyz) of a model's 3D points, model coordinates."""
    ids = np.array(sorted(reconstruction.points3D), dtype=np.int64)
    xyz = np.array([reconstruction.points3D[int(i)].xyz for i in ids], dtype=float).reshape(-1, 3)
    return ids, xyz


def camera_depths(reconstruction: pycolmap.Reconstruction, image_id: int, pose: ModelPose,
                  point_ids: np.ndarray, xyz: np.ndarray) -> np.ndarray:
    """Depths (along the optical axis, model units) of the 3D points an image observes, > 0 only."""
    observed = np.array([p.point3D_id for p in
                         reconstruction.images[image_id].get_observation_points2D()], np.int64)
    rows = np.searchsorted(point_ids, observed)
    rows = rows[(rows < len(point_ids)) & (point_ids[np.minimum(rows, len(point_ids) - 1)]
                                           == observed)]
    depths = xyz[rows] @ pose.rotation[2] + pose.translation[2]
    return depths[depths > 0]


def camera_ranges(reconstruction: pycolmap.Reconstruction, poses: dict[int, ModelPose],
                  points: tuple[np.ndarray, np.ndarray] | None = None) -> dict[int, float | None]:
    """Median observed depth per registered image; None for an image that observes no point."""
    point_ids, xyz = point_array(reconstruction) if points is None else points
    ranges = {}
    for image_id, pose in poses.items():
        depths = camera_depths(reconstruction, image_id, pose, point_ids, xyz)
        ranges[image_id] = float(np.median(depths)) if len(depths) else None
    return ranges


def _fill_ranges(ranges: dict[int, float | None],
                 centers: np.ndarray) -> tuple[dict[int, float], float]:
    known = [r for r in ranges.values() if r is not None]
    if known:
        fallback = float(np.median(known))
    else:
        # No camera sees a point: the spread of the cameras is the only scale there is.
        extent = np.ptp(centers, axis=0).max() if len(centers) else 0.0
        fallback = float(extent) if extent > 0 else 1.0
    return {k: (fallback if r is None else r) for k, r in ranges.items()}, fallback


def _fovs(reconstructions: list[pycolmap.Reconstruction]) -> dict[int, float]:
    fovs = {}
    for reconstruction in reversed(reconstructions):  # the largest model wins
        for image_id, image in reconstruction.images.items():
            camera = reconstruction.cameras[image.camera_id]
            fovs[image_id] = geometry.horizontal_fov_deg(camera.focal_length_x, camera.width)
    return fovs


def _model_of(reconstructions: list[pycolmap.Reconstruction]) -> dict[int, int]:
    model_of: dict[int, int] = {}
    for index in reversed(range(len(reconstructions))):
        for image_id in reconstructions[index].reg_image_ids():
            model_of[image_id] = index
    return model_of


def _subsample(points_xy: np.ndarray, max_points: int, seed: int) -> np.ndarray:
    if len(points_xy) <= max_points:
        return points_xy
    keep = np.random.default_rng(seed).choice(len(points_xy), max_points, replace=False)
    return points_xy[np.sort(keep)]


def _frame(xyz: np.ndarray, poses: dict[int, ModelPose], order: list[int],
           seed: int) -> GroundFrame:
    registered = [i for i in order if i in poses]
    centers = np.array([poses[i].center for i in registered])
    ups = np.array([geometry.camera_up(poses[i].rotation) for i in registered])
    return ground_frame(xyz, centers, ups, seed)


def _camera(image_id, name, seq, model, pose, frame, fov, range_) -> SceneCamera:
    if pose is None:
        return SceneCamera(image_id, name, seq, False, model, None, None, None, fov, range_,
                           None, None)
    x, y = frame.to_2d(pose.center)[0]
    yaw = geometry.yaw_in_frame(geometry.viewing_direction(pose.rotation), frame)
    return SceneCamera(image_id, name, seq, True, model, float(x), float(y), float(yaw), fov,
                       range_, tuple(float(v) for v in pose.center),
                       tuple(float(v) for v in pose.qvec))


def build_scene(reconstructions: list[pycolmap.Reconstruction], images: list[tuple[int, str]],
                fov_by_image: dict[int, float] | None = None, max_points: int = 20000,
                seed: int = 0) -> TopDownScene:
    """Top-down scene of the largest model (first): frame, cameras by name order, 2D points."""
    if not reconstructions or reconstructions[0].num_reg_images() == 0:
        raise EmptyModel("no sparse model with registered images to build a scene from")
    largest = reconstructions[0]
    ordered = sorted(images, key=lambda item: (item[1], item[0]))
    poses = model_poses(largest)
    points = point_array(largest)
    frame = _frame(points[1], poses, [i for i, _ in ordered], seed)
    ranges, scene_range = _fill_ranges(camera_ranges(largest, poses, points),
                                       np.array([p.center for p in poses.values()]))
    # Refined intrinsics of a model beat the database's prior focal length.
    fovs = dict(fov_by_image or {}) | _fovs(reconstructions)
    model_of = _model_of(reconstructions)
    cameras = [
        _camera(image_id, name, seq, model_of.get(image_id), poses.get(image_id), frame,
                fovs.get(image_id), ranges.get(image_id, scene_range))
        for seq, (image_id, name) in enumerate(ordered)
    ]
    points_xy = _subsample(frame.to_2d(points[1]), max_points, seed)
    models = [{"index": i, "num_images": int(r.num_reg_images())}
              for i, r in enumerate(reconstructions)]
    return TopDownScene(frame, cameras, points_xy, models)
