"""Join split models by the user's placement: when an edit set places the cameras of a model other
than the largest (a group move), that model is carried into the largest model's world by the
similarity the placements imply and merged into it (cameras at their carried poses, its points
with their tracks), so the re-map starts from one model. Nothing in the matches links the two
parts (that is why COLMAP split them); the placement is the link.

Sub-models that do share registered images with the largest (COLMAP re-registers up to 20 of
them in a new model) are joined by those images instead, once, after a large cold map
(join_overlapping)."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pycolmap

from guided_sfm.core import geometry, ground_plane, metrics
from guided_sfm.core.colmap_model import ModelPose, model_poses, to_sim3d
from guided_sfm.core.group_pose import spacing
from guided_sfm.core.types import CameraEdit, GroundFrame

# A sub-model is joined when the edit set places at least this share of its cameras.
MIN_PLACED_SHARE = 0.5
# Sub-models of a cold map join the largest by the images both registered when they share at
# least this many (a similarity needs 3; docs/engine.md "Matching at scale").
MIN_SHARED_IMAGES = 3


def placed_groups(models: list[Mapping[int, ModelPose]], placements: list[CameraEdit]) -> list[int]:
    """Indexes (>= 1) of the sub-models (their poses, largest first) whose cameras the placements
    mostly place."""
    placed = {c.image_id for c in placements}
    out = []
    for index, poses in enumerate(models[1:], start=1):
        ids = set(poses)
        if ids and len(ids & placed) >= MIN_PLACED_SHARE * len(ids):
            out.append(index)
    return out


def _lifted(edit: CameraEdit, frame: GroundFrame, up: np.ndarray,
            level: float) -> tuple[np.ndarray, np.ndarray]:
    """A placement's centre and heading in 3D: the frame's plane lifted along the frame's up onto
    the plane at the largest model's camera height along its cameras' mean up (level), so that a
    ground frame tilted from the cameras' up (a plane fitted to a wall) does not tilt the join."""
    yaw = np.radians(edit.yaw_deg)
    along = float(frame.up @ up)
    base = frame.origin + edit.x * frame.x_axis + edit.y * frame.y_axis
    flat = np.cos(yaw) * frame.x_axis + np.sin(yaw) * frame.y_axis
    heading = flat - (flat @ up) / along * frame.up
    return base + (level - base @ up) / along * frame.up, heading / np.linalg.norm(heading)


def _horizontal(direction: np.ndarray, up: np.ndarray) -> np.ndarray:
    flat = direction - (direction @ up) * up
    return flat / (np.linalg.norm(flat) or 1.0)


def group_similarity(poses: Mapping[int, ModelPose], placements: list[CameraEdit],
                     frame: GroundFrame, up: np.ndarray, level: float, largest_spacing: float
                     ) -> metrics.Similarity | None:
    """The similarity carrying the sub-model (its poses) onto its placements: centres onto the
    placed centres, headings onto the placed yaws, its cameras' mean up onto the largest model's
    cameras' mean up (up; level: their height along it)."""
    edits = [c for c in placements if c.image_id in poses]
    if not edits:
        return None
    own_up = ground_plane.mean_up([geometry.camera_up(poses[c.image_id].rotation) for c in edits])
    src_c = np.array([poses[c.image_id].center for c in edits])
    src_d = np.array([_horizontal(geometry.viewing_direction(poses[c.image_id].rotation), own_up)
                      for c in edits])
    lifted = [_lifted(c, frame, up, level) for c in edits]
    dst_c, dst_d = np.array([p for p, _ in lifted]), np.array([d for _, d in lifted])
    own = spacing(src_c) or 1.0
    scale = largest_spacing / own if largest_spacing > 0 else 1.0
    src = np.vstack([src_c, src_c + own * src_d, src_c + own * own_up])
    dst = np.vstack([dst_c, dst_c + own * scale * dst_d, dst_c + own * scale * up])
    s, rotation, translation = metrics.umeyama(src, dst)
    return metrics.Similarity(s, rotation, translation)


def merge_into(largest: pycolmap.Reconstruction, other: pycolmap.Reconstruction) -> int:
    """Add other's registered images (posed as in other) and its points to largest; returns the
    number of images added. Both come from the same database, so image ids agree. Images the
    largest already has stay as they are (sub-models of one map may share some): other's points
    keep their observations in the added images only, and are dropped when that leaves one of
    a track that had more."""
    added: set[int] = set()
    for image_id in sorted(other.reg_image_ids()):
        if largest.exists_image(image_id):
            continue
        image = other.image(image_id)
        if not largest.exists_camera(image.camera_id):
            largest.add_camera_with_trivial_rig(other.camera(image.camera_id))
        fresh = pycolmap.Image(name=image.name, keypoints=np.array([p.xy for p in image.points2D]),
                               camera_id=image.camera_id, image_id=image_id)
        largest.add_image_with_trivial_frame(fresh, image.cam_from_world())
        added.add(image_id)
    for point in other.points3D.values():
        kept = [e for e in point.track.elements if e.image_id in added]
        if len(kept) >= min(2, point.track.length()):
            largest.add_point3D(point.xyz, pycolmap.Track(kept), point.color)
    return len(added)


def placed_similarities(models: list[Mapping[int, ModelPose]], placements: list[CameraEdit],
                        frame: GroundFrame) -> dict[int, metrics.Similarity]:
    """Per placed sub-model (index >= 1 into models: their poses, largest first), the similarity
    carrying it into the largest model's world (group_similarity), as join_placed joins it; the
    default rule reads a placed sub-model's evidence through it (rule.evidence.gather)."""
    groups = placed_groups(models, placements)
    if not groups:
        return {}
    poses = sorted(models[0].values(), key=lambda p: p.name)
    centers = np.array([p.center for p in poses])
    up = ground_plane.mean_up([geometry.camera_up(p.rotation) for p in poses])
    level = float(np.median(centers @ up))
    found = {index: group_similarity(models[index], placements, frame, up, level, spacing(centers))
             for index in groups}
    return {index: sim for index, sim in found.items() if sim is not None}


def join_placed(models: list[pycolmap.Reconstruction], placements: list[CameraEdit],
                frame: GroundFrame) -> tuple[list[pycolmap.Reconstruction], set[int]]:
    """(models with every placed sub-model merged into the largest, the image ids joined)."""
    poses = [model_poses(model) for model in models]
    groups = placed_groups(poses, placements)
    if not groups:
        return models, set()
    largest = pycolmap.Reconstruction(models[0])
    joined: set[int] = set()
    for index, sim in placed_similarities(poses, placements, frame).items():
        other = pycolmap.Reconstruction(models[index])
        other.transform(to_sim3d(sim))
        merge_into(largest, other)
        joined |= set(other.reg_image_ids())
    rest = [m for i, m in enumerate(models[1:], start=1) if i not in groups]
    return [largest, *rest], joined


def _pose_similarity(source: pycolmap.Reconstruction, target: pycolmap.Reconstruction,
                     touched: set[int]) -> metrics.Similarity | None:
    """The similarity taking source's untouched cameras onto target's, by their centres and
    their viewing and up directions: centres alone leave a straight leg free to turn about its
    line."""
    src_poses, dst_poses = model_poses(source), model_poses(target)
    common = sorted((set(src_poses) & set(dst_poses)) - touched)
    if len(common) < 3:
        return None

    def points(poses):
        centers = np.array([poses[i].center for i in common])
        unit = spacing(centers) or 1.0
        ahead = [geometry.viewing_direction(poses[i].rotation) for i in common]
        up = [geometry.camera_up(poses[i].rotation) for i in common]
        return np.vstack([centers, centers + unit * np.array(ahead), centers + unit * np.array(up)])

    return metrics.Similarity(*metrics.umeyama(points(src_poses), points(dst_poses)))


def join_placed_after_map(models: list[pycolmap.Reconstruction], base: pycolmap.Reconstruction,
                          touched: set[int], placements: list[CameraEdit], frame: GroundFrame
                          ) -> list[pycolmap.Reconstruction]:
    """Models of a re-map (largest first) with every sub-model the placements mostly place joined
    as join_placed joins them before the map; the models as they were when none is.

    A leg with no match to the rest is mapped as a model of its own however it was joined
    before; the placements join it again. The anchor is the model holding most of the untouched
    images, carried onto the base by them (identity for a warm start that kept them fixed), as
    the placements are in the base's frame."""
    if len(models) < 2 or not placements:
        return models
    kept = max(range(len(models)), key=lambda i: len(set(models[i].reg_image_ids()) - touched))
    sim = _pose_similarity(models[kept], base, touched)
    if sim is None:
        return models
    anchor = pycolmap.Reconstruction(models[kept])
    anchor.transform(to_sim3d(sim))
    merged, joined = join_placed([anchor, *(m for i, m in enumerate(models) if i != kept)],
                                 placements, frame)
    if not joined:
        return models
    return sorted(merged, key=lambda m: -m.num_reg_images())


def join_overlapping(models: list[pycolmap.Reconstruction],
                     min_shared: int = MIN_SHARED_IMAGES) -> list[pycolmap.Reconstruction]:
    """Models (largest first) with every sub-model that shares at least min_shared registered
    images with the largest carried into its world and merged into it; the others as they were.

    COLMAP's incremental mapper starts a new model where it cannot go on (a turn seen by too
    few views) and lets the new one re-register up to 20 images of the old (max_model_overlap);
    its hierarchical mapper merges such models, its incremental one leaves them apart. The
    similarity is COLMAP's own (the shared images' 3D points reprojected, RANSAC), as in its
    hierarchical merge; a sub-model it cannot align stays apart.
    """
    if len(models) < 2:
        return models
    largest, rest = pycolmap.Reconstruction(models[0]), []
    for model in models[1:]:
        shared = largest.find_common_reg_image_ids(model)
        sim = (pycolmap.align_reconstructions_via_reprojections(model, largest)
               if len(shared) >= min_shared else None)
        if sim is None:
            rest.append(model)
            continue
        other = pycolmap.Reconstruction(model)
        other.transform(sim)
        merge_into(largest, other)
    if len(rest) == len(models) - 1:
        return models
    return [largest, *sorted(rest, key=lambda m: -m.num_reg_images())]
