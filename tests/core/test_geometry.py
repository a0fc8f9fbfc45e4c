import numpy as np
import pycolmap
import pytest

from guided_sfm.core import geometry
from guided_sfm.core.types import GroundFrame
from guided_sfm.sample.geometry import look

FLAT = GroundFrame(np.zeros(3), np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), np.array([0, 0, 1.0]))


def _random_rotations(count: int, seed: int = 0) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    return [geometry.rotation_from_qvec(q) for q in rng.normal(size=(count, 4))]


def test_quaternion_round_trip_including_half_turns():
    rotations = _random_rotations(50) + [np.diag([1.0, -1, -1]), np.diag([-1.0, -1, 1])]
    for rotation in rotations:
        qvec = geometry.qvec_from_rotation(rotation)
        assert qvec[0] >= 0
        np.testing.assert_allclose(geometry.rotation_from_qvec(qvec), rotation, atol=1e-12)


def test_pycolmap_quaternion_order_is_converted():
    rotation = _random_rotations(1, seed=3)[0]
    quat_xyzw = pycolmap.Rotation3d(rotation).quat
    qvec = geometry.qvec_from_pycolmap(quat_xyzw)
    np.testing.assert_allclose(geometry.rotation_from_qvec(qvec), rotation, atol=1e-9)


def test_level_camera_centre_direction_up_and_yaw():
    cam_from_world_rotation, translation = look([2.0, -1.0, 1.5], yaw_deg=30.0)
    np.testing.assert_allclose(geometry.camera_centers(cam_from_world_rotation, translation),
                               [2.0, -1.0, 1.5], atol=1e-12)
    direction = geometry.viewing_direction(cam_from_world_rotation)
    np.testing.assert_allclose(direction, [np.cos(np.radians(30)), np.sin(np.radians(30)), 0],
                               atol=1e-12)
    np.testing.assert_allclose(geometry.camera_up(cam_from_world_rotation), [0, 0, 1], atol=1e-12)
    assert geometry.yaw_in_frame(direction, FLAT) == pytest.approx(30.0)


@pytest.mark.parametrize(("angle", "wrapped"), [
    (0, 0), (180, 180), (-180, 180), (190, -170), (-190, 170), (540, 180), (-540, 180),
    (359.5, -0.5), (720, 0),
])
def test_wrap_deg_to_half_open_interval(angle, wrapped):
    assert geometry.wrap_deg(angle) == pytest.approx(wrapped)


def test_yaw_wraps_around_behind():
    directions = np.array([[np.cos(np.radians(a)), np.sin(np.radians(a)), 0] for a in (179, 181)])
    np.testing.assert_allclose(geometry.yaw_in_frame(directions, FLAT), [179, -179])
    assert geometry.yaw_in_frame(np.array([-1.0, 0, 0]), FLAT) == pytest.approx(180.0)


def test_rotation_angle_and_fov():
    a = look([0, 0, 0], 0.0)[0]
    b = look([0, 0, 0], 25.0)[0]
    assert geometry.rotation_angles_deg(a, b) == pytest.approx(25.0)
    assert geometry.rotation_angles_deg(a, a) == pytest.approx(0.0, abs=1e-6)
    assert geometry.horizontal_fov_deg(320.0, 640.0) == pytest.approx(90.0)


def test_batched_centres_and_angles_agree_with_one_camera_at_a_time():
    poses = [look([x, 2.0 - x, 1.5], yaw_deg=40.0 * x, pitch_deg=-5.0) for x in range(4)]
    rotations, translations = np.array([p[0] for p in poses]), np.array([p[1] for p in poses])
    np.testing.assert_allclose(geometry.camera_centers(rotations, translations),
                               [[x, 2.0 - x, 1.5] for x in range(4)], atol=1e-12)
    angles = geometry.rotation_angles_deg(rotations[0], rotations)
    np.testing.assert_allclose(angles, [0.0, 40.0, 80.0, 120.0], atol=1e-5)
    assert geometry.rotation_angles_deg(rotations[:, None], rotations[None]).shape == (4, 4)


def test_rotations_about_an_axis_turn_right_handed():
    turns = geometry.rotations_about(np.array([0, 0, 2.0]), np.radians([90.0, 180.0]))
    np.testing.assert_allclose(turns[0] @ [1.0, 0, 0], [0, 1.0, 0], atol=1e-12)
    np.testing.assert_allclose(turns[1] @ [1.0, 0, 0], [-1.0, 0, 0], atol=1e-12)


def test_segment_median_and_yaw_slack():
    values = np.array([10.0, 350.0, 30.0, 5.0, 7.0, 1.0])
    segments = np.array([0, 0, 0, 2, 2, 2])
    medians = geometry.segment_median(values, segments, 4)
    np.testing.assert_allclose(medians[[0, 2]], [30.0, 5.0])
    assert np.isnan(medians[[1, 3]]).all()
    np.testing.assert_allclose(geometry.segment_median(np.array([1.0, 3.0]), np.array([0, 0]), 1), [2.0])
    np.testing.assert_allclose(geometry.yaw_slack_deg(20.0, 10.0, np.array([0, 1, 2, 3])),
                               [20.0, 20.0, 30.0, 40.0])


@pytest.mark.parametrize("share", [0.0, 0.25, 0.4, 0.5, 1.0])
def test_segment_quantile_is_numpys_per_segment(share):
    rng = np.random.default_rng(4)
    segments = np.sort(rng.integers(0, 6, 60))
    values = rng.uniform(0, 359, 60)
    found = geometry.segment_quantile(values, segments, 7, share)
    for segment in range(7):
        chosen = values[segments == segment]
        if len(chosen):
            assert found[segment] == pytest.approx(np.quantile(chosen, share))
        else:
            assert np.isnan(found[segment])
