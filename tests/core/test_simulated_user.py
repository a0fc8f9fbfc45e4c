"""The simulated users of the headless loop, on hand-made truths."""

import numpy as np
import pytest

from guided_sfm.core.metrics import Similarity
from guided_sfm.core.simulated_user import place_on_circle
from guided_sfm.core.truth import Truth, TruthCamera
from guided_sfm.core.types import SceneCamera, TopDownScene

from .synthetic import FRAME, look_at

CENTER = np.array([2.0, -1.0])


def _orbit_truth(angles_deg: list[float], radius: float = 2.5) -> Truth:
    cameras = {}
    for index, angle in enumerate(np.radians(angles_deg)):
        center = np.array([*(CENTER + radius * np.array([np.cos(angle), np.sin(angle)])), 1.5])
        rotation, translation = look_at(center, CENTER)
        cameras[f"{index:04d}.jpg"] = TruthCamera(rotation, translation, center)
    return Truth(np.array([0, 0, 1.0]), cameras, None, None)


def _scene(names: list[str]) -> TopDownScene:
    # where the model put them does not matter to this user: only the image ids are used
    return TopDownScene(FRAME, [SceneCamera(i + 1, n, i, False, None, *[None] * 7)
                                for i, n in enumerate(names)], np.zeros((0, 2)))


def test_a_capture_shape_user_lays_the_orbit_evenly_in_capture_order():
    # the photos were not taken evenly: the user re-lays them by their order alone
    angles = [-90.0, -75.0, -71.0, -40.0, 0.0, 12.0, 60.0, 90.0]
    truth = _orbit_truth(angles)
    names = sorted(truth.cameras)
    identity = Similarity(1.0, np.eye(3), np.zeros(3))
    edits = place_on_circle(_scene(names), truth, names[::-1], identity, offset_m=0.0,
                            yaw_noise_deg=0.0)
    assert [e.image_id for e in edits] == list(range(1, len(names) + 1))
    spots = np.array([[e.x, e.y] for e in edits]) - CENTER
    assert np.linalg.norm(spots, axis=1) == pytest.approx(2.5)
    laid = np.degrees(np.unwrap(np.arctan2(spots[:, 1], spots[:, 0])))
    assert laid == pytest.approx(np.linspace(-90.0, 90.0, len(names)))
    inward = np.degrees(np.arctan2(-spots[:, 1], -spots[:, 0]))
    assert [e.yaw_deg for e in edits] == pytest.approx(inward)


def test_rotation_keys_take_big_steps_then_small_ones():
    from guided_sfm.core.simulated_user import key_presses_to_turn

    assert key_presses_to_turn(0) == 0
    assert key_presses_to_turn(-24) == 4  # two shift presses (20 deg), two plain ones (4 deg)
    assert key_presses_to_turn(350) == 1  # the short way round: -10 deg
    assert key_presses_to_turn(180) == 18
