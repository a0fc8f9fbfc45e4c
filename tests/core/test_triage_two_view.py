"""Where a pair's own matches put one camera seen from the other (two_view hops), on made-up
cameras and points."""

import numpy as np
import pycolmap

from guided_sfm.core.colmap_model import ModelPose
from guided_sfm.core.triage import poses2d, two_view
from guided_sfm.core.types import GroundFrame

FRAME = GroundFrame(np.zeros(3), np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), np.array([0, 0, 1.0]))


def _rotation(yaw_deg):
    """cam_from_world of a level camera looking along yaw (deg CCW from +x, z up)."""
    c, s = np.cos(np.radians(yaw_deg)), np.sin(np.radians(yaw_deg))
    forward, down = np.array([c, s, 0.0]), np.array([0.0, 0.0, -1.0])
    return np.stack([np.cross(down, forward), down, forward])


def _pose(center, yaw_deg):
    rotation = _rotation(yaw_deg)
    return ModelPose("a.jpg", rotation, -rotation @ center, np.asarray(center, float), np.zeros(4))


def test_a_hop_is_the_other_camera_seen_from_the_first_with_the_first_ones_points_for_scale():
    rng = np.random.default_rng(3)
    camera = pycolmap.Camera.create_from_model_id(1, pycolmap.CameraModelId.SIMPLE_PINHOLE,
                                                  500.0, 640, 480)
    start, to = _pose(np.array([1.0, 2.0, 1.5]), 30.0), _pose(np.array([3.5, 3.0, 1.5]), 75.0)
    points = np.array([4.0, 6.0, 1.0]) + rng.uniform(-1.5, 1.5, (60, 3))
    seen = points @ to.rotation.T + to.translation
    xy_to = camera.img_from_cam(seen)
    to_from_start = to.rotation @ start.rotation.T
    t = to.rotation @ (start.center - to.center)
    ids, xyz = np.arange(len(points)), points.copy()
    xyz[::10] += rng.uniform(-2, 2, (6, 3))  # a few points the model holds elsewhere
    hop = two_view._hop(start, camera, xy_to, ids.copy(), ids, xyz, to_from_start,
                        t / np.linalg.norm(t), FRAME)
    expected = poses2d.between(poses2d.pose(1.0, 2.0, 30.0), poses2d.pose(3.5, 3.0, 75.0))
    assert np.allclose(hop[:2], expected[:2], atol=0.02)
    assert abs(hop[2] - expected[2]) < 1e-6


def test_a_baseline_the_points_disagree_on_is_none():
    rng = np.random.default_rng(4)
    rays = np.hstack([rng.uniform(-0.3, 0.3, (30, 2)), np.ones((30, 1))])
    points = rng.uniform(1, 8, (30, 3)) * [1, 1, 1]  # unrelated to the rays
    assert two_view._baseline(np.eye(3), np.array([1.0, 0, 0]), points, rays) is None
