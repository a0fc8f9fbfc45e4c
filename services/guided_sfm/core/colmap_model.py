"""Sparse models: load them largest first, read their camera poses (the one place that asks
pycolmap for them), and align one version's models to another's."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pycolmap

from guided_sfm.core import geometry, metrics

# Alignment between versions is robust to the cameras a round moved: inliers must agree
# within this share of the diagonal of the cameras' bounding box.
ALIGN_THRESHOLD_SHARE = 0.02


def load_models_with_dirs(sparse_dir: Path) -> list[tuple[Path, pycolmap.Reconstruction]]:
    """(folder, model) of every model under sparse_dir (0/, 1/, ...), largest (most registered
    images) first."""
    dirs = sorted((d for d in Path(sparse_dir).iterdir() if d.name.isdigit()), key=lambda d: int(d.name))
    return sorted(((d, pycolmap.Reconstruction(d)) for d in dirs), key=lambda m: -m[1].num_reg_images())


def load_models(sparse_dir: Path) -> list[pycolmap.Reconstruction]:
    """Every model under sparse_dir, largest first."""
    return [model for _, model in load_models_with_dirs(sparse_dir)]


@dataclass(frozen=True)
class ModelPose:
    """A registered image's pose in its model (model coordinates)."""

    name: str
    rotation: np.ndarray  # (3, 3) cam_from_world
    translation: np.ndarray  # (3,) cam_from_world
    center: np.ndarray  # (3,)
    qvec: np.ndarray  # (w, x, y, z), world-to-camera


def model_poses(model: pycolmap.Reconstruction,
                image_ids: Iterable[int] | None = None) -> dict[int, ModelPose]:
    """Pose of every registered image of a model, or of those among image_ids, by image id."""
    if image_ids is None:
        images = list(model.images.values())
    else:
        images = [model.image(i) for i in image_ids if model.exists_image(i)]
    poses = {}
    for image in images:
        if image.has_pose:
            cam_from_world = image.cam_from_world()
            rotation = cam_from_world.rotation.matrix()
            translation = np.asarray(cam_from_world.translation, dtype=float)
            poses[image.image_id] = ModelPose(
                image.name, rotation, translation, geometry.camera_centers(rotation, translation),
                geometry.qvec_from_pycolmap(cam_from_world.rotation.quat))
    return poses


def camera_poses(model: pycolmap.Reconstruction) -> dict[str, metrics.CameraPose]:
    """Image name -> (cam_from_world rotation, camera centre) of every registered image."""
    return {pose.name: (pose.rotation, pose.center) for pose in model_poses(model).values()}


def _diagonal(centers: np.ndarray) -> float:
    """The diagonal of the centres' bounding box (1 where there is none): the scale the
    alignment threshold is a share of."""
    if len(centers) < 2:
        return 1.0
    return float(np.linalg.norm(centers.max(axis=0) - centers.min(axis=0))) or 1.0


def similarity_between(source: pycolmap.Reconstruction, target: pycolmap.Reconstruction,
                       exclude_names: set[str] = frozenset()) -> metrics.Similarity | None:
    """Robust similarity taking source's camera centres onto target's (common, kept cameras)."""
    src_poses, dst_poses = camera_poses(source), camera_poses(target)
    common = sorted((set(src_poses) & set(dst_poses)) - set(exclude_names))
    if len(common) < 3:
        return None
    src = np.array([src_poses[n][1] for n in common])
    dst = np.array([dst_poses[n][1] for n in common])
    return metrics.align_similarity(src, dst, threshold=ALIGN_THRESHOLD_SHARE * _diagonal(dst))


def to_sim3d(sim: metrics.Similarity) -> pycolmap.Sim3d:
    return pycolmap.Sim3d(float(sim.scale), pycolmap.Rotation3d(np.asarray(sim.rotation)),
                          np.asarray(sim.translation, dtype=float).reshape(3, 1))


def align_models(models: list[pycolmap.Reconstruction], reference: pycolmap.Reconstruction,
                 exclude: frozenset[int] = frozenset()) -> bool:
    """Move every model onto the reference by the largest model's similarity; False if impossible."""
    excluded = {models[0].image(i).name for i in exclude if models[0].exists_image(i)}
    sim = similarity_between(models[0], reference, excluded)
    if sim is None:
        return False
    for model in models:
        model.transform(to_sim3d(sim))
    return True


def compare_models(before: pycolmap.Reconstruction, after: pycolmap.Reconstruction,
                   edited: set[str] = frozenset()) -> list[dict]:
    """Per registered camera of `after`: distance moved and angle turned since `before`, after
    aligning on the common cameras no edit moved (the `edited` names), so a re-centred re-map
    counts only what the edit really moved."""
    sim = similarity_between(after, before, edited)
    poses_before, poses_after = camera_poses(before), camera_poses(after)
    out = []
    for image_id in sorted(after.reg_image_ids()):
        name = after.image(image_id).name
        if name not in poses_before or sim is None:
            out.append({"image_id": image_id, "moved": None, "rotated_deg": None})
            continue
        rotation, center = poses_after[name]
        center = sim.apply(center[None])[0]
        rotation = rotation @ np.asarray(sim.rotation).T
        out.append({
            "image_id": image_id,
            "moved": float(np.linalg.norm(center - poses_before[name][1])),
            "rotated_deg": float(geometry.rotation_angles_deg(poses_before[name][0], rotation)),
        })
    return out
