"""What triage reads from a workspace: the cameras in capture order, the verified pairs with
their inlier counts, how many 3D points each pair shares in the largest model, and the points
each camera should have matched but did not (the missing-correspondence cue)."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pycolmap

from guided_sfm.core import colmap_db, model_files
from guided_sfm.core.colmap_model import ModelPose, model_poses
from guided_sfm.core.types import GroundFrame, PairKey, TopDownScene

# Points a camera "should see": in front of it, inside its image with this margin (share of the
# image size), nearer than this many times its typical depth (farther ones are easily occluded).
IMAGE_MARGIN_SHARE, MAX_DEPTH_RATIO = 0.05, 1.5


@dataclass(frozen=True)
class MissingCount:
    """Points observed by cameras placed near this one (others than its capture neighbours)
    that project inside its view, and how many of them it observes itself."""

    expected: int
    matched: int


@dataclass(frozen=True)
class TriageInput:
    """Everything triage judges, in the scene's 2D frame; cameras in capture order."""

    scene: TopDownScene
    pairs: dict[PairKey, int]
    shared_points: dict[PairKey, int] = field(default_factory=dict)
    missing: dict[int, MissingCount] = field(default_factory=dict)
    anchors: list = field(default_factory=list)  # two_view.Anchor of pairs the model cannot hold
    # per pair: ground positions (N, 2) of the 3D points its matches join that the model holds
    # as two different points, the first image's then the second's (symmetry.py)
    split_points: dict[PairKey, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    # (start, to) -> where a capture neighbour's matches put `to` in start's ground frame, as a
    # 2D pose (two_view.hops_of), for the neighbours across each break
    hops: dict[tuple[int, int], np.ndarray] = field(default_factory=dict)
    # per model index: its 3D points on the ground plane where its cameras are (the largest
    # model's as placed, another's at its group poses), for the walls' direction (walls.py)
    ground_points: dict[int, np.ndarray] = field(default_factory=dict)


@dataclass(frozen=True)
class ModelReads:
    """The largest model's files as triage reads them, once: per registered image its 2D points
    ((N, 2) keypoints in pixels, (N,) point3D id or -1), and the 3D points (sorted ids, xyz)."""

    observations: dict[int, tuple[np.ndarray, np.ndarray]]
    points: tuple[np.ndarray, np.ndarray]


def read_model(model_dir: Path, poses: dict[int, ModelPose]) -> ModelReads:
    return ModelReads(model_files.read_observations(model_dir, poses), model_files.read_points(model_dir))


# A pair's split points are read when at least this many of its inliers are not shared points.
MIN_SPLIT = 10


def split_points(database: Path, reads: ModelReads, frame: GroundFrame, pairs: dict[PairKey, int],
                 shared: dict[PairKey, int]) -> dict[PairKey, tuple[np.ndarray, np.ndarray]]:
    """Per verified pair of registered images: the ground positions of the 3D points its inlier
    matches join that the model holds as two different points (first image's, second's)."""
    wanted = [k for k, n in pairs.items() if k in shared and n - shared[k] >= MIN_SPLIT]
    if not wanted:
        return {}
    observations, (ids, xyz) = reads.observations, reads.points
    out = {}
    for (a, b), rows in colmap_db.inlier_matches_of(database, wanted).items():
        held_a, held_b = observations[a][1], observations[b][1]
        # a model may hold fewer 2D points than the database has keypoints (known poses only)
        rows = rows[(rows[:, 0] < len(held_a)) & (rows[:, 1] < len(held_b))]
        point_a, point_b = held_a[rows[:, 0]], held_b[rows[:, 1]]
        split = ((point_a != model_files.NO_POINT) & (point_b != model_files.NO_POINT)
                 & (point_a != point_b))
        if split.any():
            out[(a, b)] = (frame.to_2d(model_files.points_of(point_a[split], ids, xyz)),
                           frame.to_2d(model_files.points_of(point_b[split], ids, xyz)))
    return out


def shared_point_counts(observed: dict[int, np.ndarray], pairs: Iterable[PairKey]) -> dict[PairKey, int]:
    """Per pair of registered images: how many 3D points of the model both observe."""
    sets = {i: set(ids.tolist()) for i, ids in observed.items()}
    return {p: len(sets[p[0]] & sets[p[1]]) for p in pairs if p[0] in sets and p[1] in sets}


def observed_points(reads: ModelReads) -> dict[int, np.ndarray]:
    """Per registered image: the ids of the 3D points it observes (unique)."""
    return {i: np.unique(ids[ids != model_files.NO_POINT]) for i, (_, ids) in reads.observations.items()}


def _in_view(pose: ModelPose, camera: pycolmap.Camera, xyz: np.ndarray, depth: float) -> np.ndarray:
    """Mask of the points that project inside the camera's image, in front, nearer than depth."""
    cam = xyz @ pose.rotation.T + pose.translation
    front = (cam[:, 2] > 1e-6) & (cam[:, 2] < depth)
    pixels = np.full((len(xyz), 2), -1e9)
    if front.any():
        pixels[front] = camera.img_from_cam(cam[front])
    margin_x, margin_y = IMAGE_MARGIN_SHARE * camera.width, IMAGE_MARGIN_SHARE * camera.height
    inside = ((pixels[:, 0] > margin_x) & (pixels[:, 0] < camera.width - margin_x)
              & (pixels[:, 1] > margin_y) & (pixels[:, 1] < camera.height - margin_y))
    return front & inside


def typical_step(scene: TopDownScene) -> float:
    """Median 2D distance between capture-order neighbours that are both in the largest model."""
    placed = [c for c in scene.cameras if c.registered]
    xy = np.array([(c.x, c.y) for c in placed]).reshape(-1, 2)
    steps = np.linalg.norm(np.diff(xy, axis=0), axis=1)
    return float(np.median(steps)) if len(steps) else 1.0


def _near_others(scene: TopDownScene, radius: float, window: int) -> dict[int, np.ndarray]:
    """Per registered camera: the registered cameras placed within radius of it, more than
    window apart in capture order."""
    placed = [c for c in scene.cameras if c.registered]
    ids = np.array([c.image_id for c in placed], dtype=np.int64)
    seq = np.array([c.seq for c in placed])
    xy = np.array([(c.x, c.y) for c in placed]).reshape(-1, 2)
    return {int(i): ids[(np.abs(seq - s) > window) & (np.hypot(*(xy - p).T) <= radius)]
            for i, s, p in zip(ids, seq, xy, strict=True)}


def missing_counts(model: pycolmap.Reconstruction, reads: ModelReads, scene: TopDownScene,
                   radius_steps: float = 3.0, window: int = 3,
                   observed: dict[int, np.ndarray] | None = None) -> dict[int, MissingCount]:
    """The missing-correspondence cue per registered camera: of the 3D points seen by cameras
    from elsewhere in the capture placed within radius_steps typical steps of it, those inside
    its view and depth, how many it observes itself (observed: observed_points, if made)."""
    poses = model_poses(model)
    observed = observed_points(reads) if observed is None else observed
    ids, xyz = reads.points
    radius = radius_steps * typical_step(scene)
    near = _near_others(scene, radius, window)
    out = {}
    for camera in scene.cameras:
        if not camera.registered or camera.image_id not in poses:
            continue
        others = near[camera.image_id].tolist()
        candidates = np.setdiff1d(np.unique(np.concatenate(
            [observed[o] for o in others if o in observed] or [np.empty(0, np.int64)])), [])
        if not len(candidates):
            out[camera.image_id] = MissingCount(0, 0)
            continue
        points = model_files.points_of(candidates, ids, xyz)
        seen = _in_view(poses[camera.image_id], model.cameras[model.image(camera.image_id).camera_id],
                        points, MAX_DEPTH_RATIO * (camera.range or 1.0))
        expected = candidates[seen]
        matched = np.intersect1d(expected, observed[camera.image_id])
        out[camera.image_id] = MissingCount(len(expected), len(matched))
    return out


def gather(scene: TopDownScene, pairs: dict[PairKey, int], model: pycolmap.Reconstruction | None,
           reads: ModelReads | None) -> TriageInput:
    """TriageInput of a workspace's scene, verified pairs and largest model (None: no model)."""
    if model is None or reads is None:
        return TriageInput(scene, pairs)
    observed = observed_points(reads)
    return TriageInput(scene, pairs, shared_point_counts(observed, pairs),
                       missing_counts(model, reads, scene, observed=observed))
