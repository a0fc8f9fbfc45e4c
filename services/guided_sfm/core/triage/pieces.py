"""Cut the capture into pieces: capture-order stretches placed continuously in one model. A piece
of the largest model ends where continuity breaks (signals.Step.breaks); cameras of another model
form pieces of their own (placed by their group poses), and so do cameras in no model."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from guided_sfm.core.triage import poses2d
from guided_sfm.core.triage.signals import Step
from guided_sfm.core.types import SceneCamera

PLACED, GROUP, LOOSE = "placed", "group", "loose"  # in the largest model, in another, in none


@dataclass
class Piece:
    """One stretch of the capture; poses (N, 3) in the scene's 2D frame (None for loose ones)."""

    kind: str
    cameras: list[SceneCamera]
    poses: np.ndarray | None
    break_before: Step | None = None  # the step that cut it from the piece before
    break_after: Step | None = None

    @property
    def image_ids(self) -> list[int]:
        return [c.image_id for c in self.cameras]

    @property
    def names(self) -> str:
        first, last = self.cameras[0].name, self.cameras[-1].name
        return first if first == last else f"{first}-{last}"


def _kind(camera: SceneCamera, group_poses: dict[int, tuple[float, float, float]]) -> str:
    if camera.registered:
        return PLACED
    return GROUP if camera.image_id in group_poses else LOOSE


def _pose_of(camera: SceneCamera, group_poses: dict[int, tuple[float, float, float]]):
    if camera.registered:
        return poses2d.pose(camera.x, camera.y, camera.yaw_deg)
    if camera.image_id in group_poses:
        return poses2d.pose(*group_poses[camera.image_id])
    return None


def cut_pieces(cameras: list[SceneCamera], steps: list[Step],
               group_poses: dict[int, tuple[float, float, float]]) -> list[Piece]:
    """The capture (cameras in capture order) cut at every break, every change of model."""
    breaking = {s.before.image_id: s for s in steps if s.breaks}
    pieces: list[Piece] = []
    current: list[SceneCamera] = []
    pending_break: Step | None = None
    for camera in cameras:
        if current and (_key(camera, group_poses) != _key(current[-1], group_poses)):
            pieces.append(_piece(current, group_poses, pending_break))
            current, pending_break = [], None
        current.append(camera)
        step = breaking.get(camera.image_id)
        if step is not None:
            pieces.append(_piece(current, group_poses, pending_break, step))
            current, pending_break = [], step
    if current:
        pieces.append(_piece(current, group_poses, pending_break))
    return pieces


def _key(camera: SceneCamera, group_poses) -> tuple[str, int | None]:
    return _kind(camera, group_poses), camera.model


def _piece(cameras, group_poses, before: Step | None, after: Step | None = None) -> Piece:
    kind = _kind(cameras[0], group_poses)
    poses = None if kind == LOOSE else np.array([_pose_of(c, group_poses) for c in cameras])
    return Piece(kind, list(cameras), poses, before, after)
