"""The top-down scene (design.md step 3) built from pycolmap reconstructions."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pycolmap

from guided_sfm.core import geometry, group_pose, model_files
from guided_sfm.core.colmap_model import ModelPose, model_poses
from guided_sfm.core.errors import EmptyModel
from guided_sfm.core.ground_plane import ground_frame
from guided_sfm.core.types import GroundFrame, SceneCamera, TopDownScene


def camera_ranges(model_dir: Path, poses: dict[int, ModelPose],
                  points: tuple[np.ndarray, np.ndarray]) -> dict[int, float | None]:
    """Median depth (along the optical axis, model units) of the 3D points each registered image
    of the model at model_dir observes; None for an image that observes none in front of it.
    points: that model's read_points."""
    observations = model_files.read_observations(model_dir, poses)
    ranges = {}
    for image_id, pose in poses.items():
        xyz = model_files.points_of(observations[image_id][1], *points)
        depths = xyz @ pose.rotation[2] + pose.translation[2]
        depths = depths[depths > 0]  # NaN (no point) is not
        ranges[image_id] = float(np.median(depths)) if len(depths) else None
    return ranges


def _fill_ranges(ranges: dict[int, float | None],
                 centers: np.ndarray) -> tuple[dict[int, float], float]:
    known = [r for r in ranges.values() if r is not None]
    if known:
        fallback = float(np.median(known))
    else:
        # No camera sees a point: the spread of the cameras (the longest side of their bounding
        # box) is the only scale there is.
        longest_side = np.ptp(centers, axis=0).max() if len(centers) else 0.0
        fallback = float(longest_side) if longest_side > 0 else 1.0
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


def build_scene(reconstructions: list[pycolmap.Reconstruction], largest_dir: Path,
                images: list[tuple[int, str]], fov_by_image: dict[int, float] | None = None,
                max_points: int = 20000, seed: int = 0) -> TopDownScene:
    """Top-down scene of the largest model (first; its files at largest_dir): frame, cameras by
    name order, 2D points."""
    if not reconstructions or reconstructions[0].num_reg_images() == 0:
        raise EmptyModel("no sparse model with registered images to build a scene from")
    ordered = sorted(images, key=lambda item: (item[1], item[0]))
    poses = model_poses(reconstructions[0])
    points = model_files.read_points(largest_dir)  # numpy, not one pycolmap object per point
    frame = _frame(points[1], poses, [i for i, _ in ordered], seed)
    ranges, scene_range = _fill_ranges(camera_ranges(largest_dir, poses, points),
                                       np.array([p.center for p in poses.values()]))
    # Refined intrinsics of a model beat the database's prior focal length.
    fovs = dict(fov_by_image or {}) | _fovs(reconstructions)
    model_of = _model_of(reconstructions)
    cameras = [
        _camera(image_id, name, seq, model_of.get(image_id), poses.get(image_id), frame,
                fovs.get(image_id), ranges.get(image_id, scene_range))
        for seq, (image_id, name) in enumerate(ordered)
    ]
    cameras = _with_group_poses(cameras, reconstructions, frame)
    points_xy = _subsample(frame.to_2d(points[1]), max_points, seed)
    models = [{"index": i, "num_images": int(r.num_reg_images())}
              for i, r in enumerate(reconstructions)]
    return TopDownScene(frame, cameras, points_xy, models)


def _with_group_poses(cameras: list[SceneCamera], reconstructions: list[pycolmap.Reconstruction],
                      frame: GroundFrame) -> list[SceneCamera]:
    """The cameras, those of the other models with their group_pose (design.md v1.1)."""
    if len(reconstructions) < 2:
        return cameras
    order = [c.image_id for c in cameras]
    placed = [c for c in cameras if c.registered]
    largest_xy = np.array([(c.x, c.y) for c in placed]).reshape(-1, 2)
    spacing = group_pose.spacing(np.array([c.center for c in placed]).reshape(-1, 3))
    poses: dict[int, dict[str, float]] = {}
    for index, model in enumerate(reconstructions[1:], start=1):
        own = {i: p for i, p in model_poses(model).items()
               if next((c.model for c in cameras if c.image_id == i), None) == index}
        # each group is set down beside the largest model and the groups placed before it
        placed_xy = np.vstack([largest_xy, [(p["x"], p["y"]) for p in poses.values()]]) \
            if poses else largest_xy
        poses |= group_pose.group_poses(own, order, frame, placed_xy, spacing)
    return [dataclasses.replace(c, group_pose=poses[c.image_id]) if c.image_id in poses else c
            for c in cameras]


def scene_extent(scene: TopDownScene) -> float:
    """The scene extent of design.md: the largest distance between two registered camera
    centres (model units); 1 with fewer than two."""
    centers = np.array([c.center for c in scene.cameras if c.center is not None])
    if len(centers) < 2:
        return 1.0
    return float(np.max(np.linalg.norm(centers[:, None] - centers[None], axis=2)))
