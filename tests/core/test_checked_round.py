"""The checked re-map: which moved cameras landed far from their placements."""

import dataclasses

import numpy as np
import pytest

from guided_sfm.core.checked_round import CHECK_SIGMAS, anchors, far_from_placement, in_frame
from guided_sfm.core.types import CameraEdit, EditSet, GroundFrame, SceneCamera, TopDownScene

from .synthetic import FRAME


def _camera(image_id: int, x: float, y: float, range_: float | None = 2.0) -> SceneCamera:
    registered = range_ is not None
    return SceneCamera(image_id, f"{image_id:04d}.jpg", image_id, registered, 0, x, y, 0.0, 60.0,
                       range_, (x, y, 1.5), (1.0, 0, 0, 0))


def test_a_placement_keeps_its_place_in_another_frame():
    turn = np.radians(30.0)
    other = GroundFrame(np.array([1.0, 2.0, 0.0]), np.array([np.cos(turn), np.sin(turn), 0.0]),
                        np.array([-np.sin(turn), np.cos(turn), 0.0]), np.array([0, 0, 1.0]))
    placed = CameraEdit(3, 2.0, 1.0, 45.0, fov_deg=50.0)
    moved = in_frame(placed, FRAME, other)
    # (2, 1) less the origin (1, 2) is (1, -1), read along the turned axes
    assert (moved.x, moved.y, moved.yaw_deg) == pytest.approx((np.cos(turn) - np.sin(turn),
                                                               -np.sin(turn) - np.cos(turn), 15.0))
    assert moved.fov_deg == 50.0
    back = in_frame(moved, other, FRAME)
    assert (back.x, back.y, back.yaw_deg) == pytest.approx((2.0, 1.0, 45.0))


def test_only_cameras_beyond_the_users_uncertainty_are_far():
    # range 2, position_share 0.25: one uncertainty is 0.5, the limit CHECK_SIGMAS of them
    limit = CHECK_SIGMAS * 0.5
    scene = TopDownScene(FRAME, [_camera(1, 0.0, 0.0), _camera(2, 0.0, 0.0), _camera(3, 0.0, 0.0),
                                 _camera(4, 0.0, 0.0, range_=None)], np.zeros((0, 2)))
    placements = [CameraEdit(1, limit * 0.9, 0.0, 0.0), CameraEdit(2, 0.0, limit * 1.1, 0.0),
                  CameraEdit(3, limit * 1.1, 0.0, 0.0, range=10.0),  # its own, wider range
                  CameraEdit(4, 50.0, 0.0, 0.0)]  # not registered: nothing to compare
    far = far_from_placement(scene, placements, position_share=0.25)
    assert [p.image_id for p in far] == [2]


def test_only_unmoved_registered_cameras_anchor_the_check():
    scene = TopDownScene(FRAME, [_camera(1, 0.0, 0.0), _camera(2, 1.0, 0.0), _camera(3, 2.0, 0.0),
                                 _camera(4, 0.0, 0.0, range_=None)], np.zeros((0, 2)))
    scene.cameras[3] = dataclasses.replace(scene.cameras[3], x=None, y=None)
    edits = EditSet([CameraEdit(1, 0.0, 0.0, 0.0)])
    assert anchors(scene, edits) == 2  # 2 and 3: camera 1 moved, 4 not registered
