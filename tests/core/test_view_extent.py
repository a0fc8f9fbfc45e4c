"""The view extent (core.geometry.view_extent) frames the cameras and the points near them, never
far stray points; `guided-sfm scene --png` frames its plot with it, as the editor's Fit does."""

import math

import numpy as np
import pytest

from guided_sfm.core.geometry import view_extent
from guided_sfm.core.types import GroundFrame, SceneCamera, TopDownScene


def ring(n: int = 19, radius: float = 1.0) -> np.ndarray:
    angles = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.stack([radius * np.cos(angles), radius * np.sin(angles)], axis=1)


def stray_scene(seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """An orbit of 19 cameras (radius 1) round an object, plus 5% of points 60-120 units away."""
    rng = np.random.default_rng(seed)
    near = rng.normal(scale=0.4, size=(2000, 2))
    far = rng.uniform(60, 120, size=(100, 2)) * rng.choice([-1, 1], size=(100, 2))
    return ring(), np.vstack([near, far])


def test_far_points_are_left_out_and_the_cameras_fill_the_extent():
    cameras, points = stray_scene()
    x0, y0, x1, y1 = view_extent(cameras, points)
    assert max(x1 - x0, y1 - y0) < 1.5 * 2.0  # the ring is 2 wide; no stray point stretches it
    assert np.all((cameras >= [x0, y0]) & (cameras <= [x1, y1]))  # every camera is inside


def test_near_points_beyond_the_cameras_are_framed():
    cameras = np.array([[0.0, 0.0], [10.0, 0.0]])  # a street: the facades 1.5 units to each side
    points = np.array([[x, side] for x in np.linspace(0, 10, 50) for side in (-1.5, 1.5)])
    x0, y0, x1, y1 = view_extent(cameras, points)
    assert y0 == pytest.approx(-1.5) and y1 == pytest.approx(1.5) and (x0, x1) == (0.0, 10.0)


def test_one_camera_takes_min_size_and_no_camera_takes_the_central_points():
    assert view_extent(np.array([[2.0, 3.0]]), np.zeros((0, 2)), min_size=4.0) == (0.0, 1.0, 4.0, 5.0)
    points = np.vstack([np.random.default_rng(1).uniform(0, 1, size=(1000, 2)), [[500.0, 500.0]]])
    x0, y0, x1, y1 = view_extent(np.zeros((0, 2)), points)
    assert x1 < 1.01 and y1 < 1.01
    assert view_extent(np.zeros((0, 2)), np.zeros((0, 2))) is None


def scene_of(cameras: np.ndarray, points: np.ndarray) -> TopDownScene:
    frame = GroundFrame(np.zeros(3), np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), np.array([0, 0, 1.0]))
    placed = [SceneCamera(i + 1, f"{i:04d}.jpg", i, True, 0, float(x), float(y),
                          math.degrees(math.atan2(-y, -x)), 60.0, 1.0, (float(x), float(y), 0.0), None)
              for i, (x, y) in enumerate(cameras)]
    return TopDownScene(frame, placed, points)


def test_scene_png_frames_the_cameras_not_the_stray_points(tmp_path):
    """The plot's limits: the ring of cameras spans at least a third of the longer side."""
    from guided_sfm import plot

    cameras, points = stray_scene()
    out = tmp_path / "scene.png"
    extent = plot.plot_scene(scene_of(cameras, points), out)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and extent is not None
    x0, y0, x1, y1 = extent
    camera_span = np.ptp(cameras, axis=0).max()
    assert camera_span >= max(x1 - x0, y1 - y0) / 3
