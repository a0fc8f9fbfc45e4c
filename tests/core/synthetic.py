"""Hand-made captures for the default rule: true poses, a wrongly placed cluster, and matches.

The model is the truth except for a cluster of cameras displaced by a ground motion (turn about z
plus a shift), with the points they observe; a false pair matches a point with its look-alike
elsewhere. The user's placement is the truth (plus optional noise), so carrying the cluster back
undoes the ground motion.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from guided_sfm.core.geometry import qvec_from_rotation, viewing_direction, yaw_in_frame
from guided_sfm.core.rule.evidence import Evidence
from guided_sfm.core.types import CameraEdit, EditSet, GroundFrame, SceneCamera, TopDownScene, pair_key
from guided_sfm.sample.geometry import look

FRAME = GroundFrame(np.zeros(3), np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), np.array([0, 0, 1.0]))
Pose = tuple[np.ndarray, np.ndarray]  # cam_from_world (R, t)


def look_at(center, target, pitch_deg: float = 0.0) -> Pose:
    """A level camera at center whose heading points at target on the ground."""
    yaw = np.degrees(np.arctan2(target[1] - center[1], target[0] - center[0]))
    return look(center, yaw, pitch_deg)


def ground_motion(turn_deg: float, shift) -> tuple[np.ndarray, np.ndarray]:
    """world_from_world (R, t) turning about z through the origin, then shifting."""
    c, s = np.cos(np.radians(turn_deg)), np.sin(np.radians(turn_deg))
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]]), np.asarray(shift, dtype=float)


def project(pose: Pose, points: np.ndarray) -> np.ndarray:
    """Unit rays (camera frame) towards world points."""
    rays = points @ pose[0].T + pose[1]
    return rays / np.linalg.norm(rays, axis=1, keepdims=True)


def in_view(pose: Pose, points: np.ndarray, half_fov_deg: float = 35.0) -> np.ndarray:
    rays = points @ pose[0].T + pose[1]
    return rays[:, 2] > np.cos(np.radians(half_fov_deg)) * np.linalg.norm(rays, axis=1)


@dataclass
class Capture:
    """True poses, the displaced cluster and the matches (world points per side, true world)."""

    poses: dict[int, Pose]
    cluster: set[int] = field(default_factory=set)
    motion: tuple[np.ndarray, np.ndarray] = (np.eye(3), np.zeros(3))
    matches: dict[tuple[int, int], tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    unpointed: set[int] = field(default_factory=set)  # images whose keypoints have no 3D point
    # images of a sub-model: no pose in the scene (the largest model's), their evidence carried
    # into the largest model's world as the join by their placements carries them
    outside: set[int] = field(default_factory=set)

    def match(self, a: int, b: int, points_a: np.ndarray, points_b: np.ndarray | None = None):
        """Record pair (a, b): a sees points_a, b sees points_b (default: the same points)."""
        points_b = points_a if points_b is None else points_b
        self.matches[pair_key(a, b)] = (points_a, points_b) if a < b else (points_b, points_a)

    def model_pose(self, image_id: int) -> Pose:
        rotation, translation = self.poses[image_id]
        if image_id not in self.cluster:
            return rotation, translation
        motion_r, motion_t = self.motion  # cam_from_model = cam_from_true . true_from_model
        return rotation @ motion_r.T, translation - rotation @ motion_r.T @ motion_t

    def model_point(self, image_id: int, points: np.ndarray) -> np.ndarray:
        if image_id in self.unpointed:
            return np.full_like(points, np.nan)
        return points @ self.motion[0].T + self.motion[1] if image_id in self.cluster else points

    def scene(self, fov_deg: float = 60.0, range_: float = 4.0) -> TopDownScene:
        cameras = [SceneCamera(i, f"{i:04d}.jpg", i, False, 1, None, None, None, fov_deg, range_,
                               None, None) if i in self.outside
                   else _scene_camera(i, self.model_pose(i), fov_deg, range_) for i in sorted(self.poses)]
        return TopDownScene(FRAME, cameras, np.zeros((0, 2)))

    def evidence(self) -> Evidence:
        ids = sorted(self.poses)
        rays: dict[int, list] = {i: [] for i in ids}
        points: dict[int, list] = {i: [] for i in ids}
        local = {}
        for (a, b), (points_a, points_b) in self.matches.items():
            index = []
            for image_id, seen in ((a, points_a), (b, points_b)):
                start = sum(len(r) for r in rays[image_id])
                rays[image_id].append(project(self.poses[image_id], seen))
                points[image_id].append(self.model_point(image_id, seen))
                index.append(np.arange(start, start + len(seen)))
            local[(a, b)] = np.stack(index, axis=1)
        counts = [sum(len(r) for r in rays[i]) for i in ids]
        poses = [self.model_pose(i) for i in ids]
        return Evidence(
            rows={image_id: row for row, image_id in enumerate(ids)},
            rotations=np.array([p[0] for p in poses]), translations=np.array([p[1] for p in poses]),
            offsets=np.concatenate([[0], np.cumsum(counts)]).astype(np.int64),
            rays=np.concatenate([np.zeros((0, 3))] + [r for i in ids for r in rays[i]]),
            points=np.concatenate([np.zeros((0, 3))] + [p for i in ids for p in points[i]]),
            matches=local)

    def pairs(self) -> dict[tuple[int, int], int]:
        return {key: len(points_a) for key, (points_a, _) in self.matches.items()}

    def placement(self, image_ids, rule: str = "default", shift: float = 0.0, turn_deg: float = 0.0,
                  **tolerances: float) -> EditSet:
        """The user's edit: each listed camera at its true 2D pose, off by shift and turn."""
        edits = []
        for image_id in sorted(image_ids):
            camera = _scene_camera(image_id, self.poses[image_id], 60.0, 4.0)
            edits.append(CameraEdit(image_id, camera.x + shift, camera.y, camera.yaw_deg + turn_deg))
        return EditSet(edits, rule=rule, tolerances=tolerances)


def _scene_camera(image_id: int, pose: Pose, fov_deg: float, range_: float) -> SceneCamera:
    rotation, translation = pose
    center = -rotation.T @ translation
    yaw = float(yaw_in_frame(viewing_direction(rotation), FRAME))
    return SceneCamera(image_id, f"{image_id:04d}.jpg", image_id, True, 0, float(center[0]),
                       float(center[1]), yaw, fov_deg, range_, tuple(center),
                       tuple(qvec_from_rotation(rotation)))


def scatter(rng: np.random.Generator, count: int, low, high) -> np.ndarray:
    """Uniform random points in the box [low, high] (metres)."""
    return rng.uniform(low, high, size=(count, 3))
