import numpy as np
import pytest

from guided_sfm.core.ground_plane import MIN_POINTS, fit_plane, ground_frame

UP = np.array([0.0, 0.0, 1.0])


def _tilted_ground(count: int, rng: np.random.Generator, tilt_deg: float = 10.0):
    """Points on a plane through the origin whose normal leans tilt_deg from +z towards +x."""
    tilt = np.radians(tilt_deg)
    normal = np.array([np.sin(tilt), 0.0, np.cos(tilt)])
    u = np.array([np.cos(tilt), 0.0, -np.sin(tilt)])
    v = np.array([0.0, 1.0, 0.0])
    coords = rng.uniform(-10, 10, size=(count, 2))
    noise = rng.normal(scale=0.01, size=count)
    return coords[:, :1] * u + coords[:, 1:] * v + noise[:, None] * normal, normal


def _line_of_cameras(count: int = 5, height: float = 1.5) -> np.ndarray:
    return np.array([[x, 0.0, height] for x in np.linspace(0, 10, count)])


def test_plane_recovered_with_30_percent_outliers():
    rng = np.random.default_rng(0)
    ground, normal = _tilted_ground(700, rng)
    outliers = rng.uniform([-10, -10, 0.5], [10, 10, 6], size=(300, 3))
    plane = fit_plane(np.vstack([ground, outliers]), UP, seed=0)
    # tolerance: 0.5 deg on the normal, 2 cm on the offset (noise 1 cm, 10 m wide)
    assert np.degrees(np.arccos(min(1.0, plane.normal @ normal))) < 0.5
    assert abs(plane.distances(np.zeros((1, 3)))[0]) < 0.02


def test_normal_agrees_with_cameras_up():
    rng = np.random.default_rng(1)
    ground, normal = _tilted_ground(500, rng)
    assert fit_plane(ground, UP).normal @ normal > 0.99
    assert fit_plane(ground, -UP).normal @ normal < -0.99
    frame = ground_frame(ground, _line_of_cameras(), np.tile(-UP, (5, 1)))
    assert frame.up @ normal < -0.99


def test_facade_is_not_the_ground():
    rng = np.random.default_rng(2)
    facade = np.column_stack([np.full(800, 12.0), rng.uniform(-10, 10, 800),
                              rng.uniform(0, 8, 800)])
    ground = np.column_stack([rng.uniform(-10, 10, (200, 2)), rng.normal(0, 0.01, 200)])
    frame = ground_frame(np.vstack([facade, ground]), _line_of_cameras(), np.tile(UP, (5, 1)))
    assert frame.up @ UP > np.cos(np.radians(1.0))
    assert abs(frame.origin[2]) < 0.02


def test_facade_alone_falls_back_to_cameras_plane():
    rng = np.random.default_rng(3)
    facade = np.column_stack([np.full(800, 12.0), rng.uniform(-10, 10, 800),
                              rng.uniform(0, 8, 800)])
    frame = ground_frame(facade, _line_of_cameras(), np.tile(UP, (5, 1)))
    np.testing.assert_allclose(frame.up, UP, atol=1e-12)
    np.testing.assert_allclose(frame.origin, [5.0, 0.0, 1.5], atol=1e-12)


def test_few_points_fall_back_to_cameras_plane():
    points = np.random.default_rng(4).uniform(-1, 1, size=(MIN_POINTS - 1, 3))
    assert fit_plane(points, UP) is None
    frame = ground_frame(points, _line_of_cameras(), np.tile(UP, (5, 1)))
    np.testing.assert_allclose(frame.origin, [5.0, 0.0, 1.5], atol=1e-12)


@pytest.mark.parametrize("reverse", [False, True])
def test_frame_axes_follow_capture_order_and_are_right_handed(reverse):
    rng = np.random.default_rng(5)
    ground = np.column_stack([rng.uniform(-10, 10, (300, 2)), rng.normal(0, 0.005, 300)])
    centers = _line_of_cameras()[::-1] if reverse else _line_of_cameras()
    frame = ground_frame(ground, centers, np.tile(UP, (5, 1)))
    expected_x = np.array([-1.0, 0, 0]) if reverse else np.array([1.0, 0, 0])
    np.testing.assert_allclose(frame.x_axis, expected_x, atol=1e-3)
    np.testing.assert_allclose(np.cross(frame.x_axis, frame.y_axis), frame.up, atol=1e-12)
    np.testing.assert_allclose(frame.origin, [5.0, 0.0, 0.0], atol=0.02)
    xy = frame.to_2d(centers)
    assert xy[-1, 0] > xy[0, 0]


def test_fit_is_deterministic_for_a_seed():
    rng = np.random.default_rng(6)
    ground, _ = _tilted_ground(400, rng)
    points = np.vstack([ground, rng.uniform(-10, 10, size=(200, 3))])
    a, b = fit_plane(points, UP, seed=7), fit_plane(points, UP, seed=7)
    np.testing.assert_array_equal(a.normal, b.normal)
