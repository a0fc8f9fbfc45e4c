"""The walls as a compass: a model's wall direction from its points, and a split-off model the
walk across the gap turned wrong turned back by them (issue 21)."""

import numpy as np
import pytest

from guided_sfm.core import group_pose
from guided_sfm.core.colmap_model import ModelPose
from guided_sfm.core.triage import poses2d, walls
from guided_sfm.core.triage.evidence import TriageInput
from guided_sfm.core.triage.suspects import triage
from guided_sfm.core.types import GroundFrame
from tests.core.test_triage import capture, u_turn


def room(width, depth, turn_deg, rng, per_metre=40, noise=0.02):
    """Points along the four walls of a width x depth room turned by turn_deg, with noise."""
    sides = [((0, 0), (width, 0)), ((width, 0), (width, depth)), ((width, depth), (0, depth)),
             ((0, depth), (0, 0))]
    points = []
    for start, end in sides:
        t = rng.uniform(0, 1, int(per_metre * np.hypot(*np.subtract(end, start))))[:, None]
        points.append(np.array(start) + t * np.subtract(end, start))
    xy = np.vstack(points) + rng.normal(0, noise, (sum(len(p) for p in points), 2))
    angle = np.radians(turn_deg)
    return xy @ np.array([[np.cos(angle), np.sin(angle)], [-np.sin(angle), np.cos(angle)]])


@pytest.mark.parametrize("turn_deg", [0.0, 17.0, 62.5, 133.0])
def test_a_rectangular_rooms_walls_give_their_direction_modulo_90(turn_deg):
    rng = np.random.default_rng(3)
    clutter = rng.uniform(0, 6, (150, 2))  # things in the room, not on its walls
    found = walls.wall_direction(np.vstack([room(10, 6, turn_deg, rng), clutter]), step=0.5)
    assert found is not None
    assert abs(walls.turn_onto(found, np.radians(turn_deg))) < np.radians(0.2)


def test_one_wall_alone_gives_its_direction():
    rng = np.random.default_rng(4)
    wall = np.column_stack([rng.uniform(0, 11, 400), 6 + rng.normal(0, 0.02, 400)])
    found = walls.wall_direction(wall @ np.array([[np.cos(0.3), np.sin(0.3)],
                                                  [-np.sin(0.3), np.cos(0.3)]]), step=0.6)
    assert found == pytest.approx(0.3, abs=np.radians(0.2))


def test_a_blob_or_walls_that_are_not_square_give_no_direction():
    rng = np.random.default_rng(5)
    assert walls.wall_direction(rng.normal(0, 2, (800, 2)), step=0.5) is None
    along = rng.uniform(0, 8, (2, 400))
    sixty = np.vstack([np.column_stack([along[0], np.zeros(400)]),
                       np.column_stack([along[1] * np.cos(np.pi / 3), along[1] * np.sin(np.pi / 3)])])
    assert walls.wall_direction(sixty + rng.normal(0, 0.02, sixty.shape), step=0.5) is None
    assert walls.wall_direction(np.zeros((10, 2)), step=0.5) is None  # too few points


def test_the_turn_onto_a_wall_direction_is_the_smallest_modulo_90():
    assert walls.turn_onto(np.radians(3), np.radians(1)) == pytest.approx(np.radians(-2))
    assert walls.turn_onto(np.radians(88), np.radians(1)) == pytest.approx(np.radians(3))
    assert walls.turn_onto(np.radians(40), np.radians(-40)) == pytest.approx(np.radians(10))


def _upright_camera(center, yaw_deg) -> ModelPose:
    """A level camera looking along yaw_deg in the world's xy plane (up = +z)."""
    yaw = np.radians(yaw_deg)
    view = np.array([np.cos(yaw), np.sin(yaw), 0.0])
    down = np.array([0.0, 0.0, -1.0])
    rotation = np.stack([np.cross(down, view), down, view])
    center = np.asarray(center, float)
    return ModelPose("c", rotation, -rotation @ center, center, np.zeros(4))


def test_upright_points_see_a_wall_as_a_line_where_the_fitted_ground_is_tilted():
    tilt = np.radians(25)  # a ground fitted to a model that sees one wall only
    up = np.array([0.0, -np.sin(tilt), np.cos(tilt)])
    x_axis = np.array([1.0, 0, 0])
    frame = GroundFrame(np.zeros(3), x_axis, np.cross(up, x_axis), up)
    model = {i: _upright_camera((i, 0.0, 1.5), 90.0) for i in range(5)}
    rng = np.random.default_rng(6)
    wall = np.column_stack([rng.uniform(0, 8, 300), np.full(300, 3.0), rng.uniform(0, 2.5, 300)])
    assert np.ptp(frame.to_2d(wall)[:, 1]) > 1.0  # seen along the frame's up: a wide band
    upright = group_pose.upright_points(model, frame, wall)
    assert np.ptp(upright[:, 1]) < 1e-9  # along the cameras' up: a line
    assert abs(walls.turn_onto(walls.wall_direction(upright, step=1.0), 0.0)) < np.radians(0.2)


def split_off(edge_yaw_error_deg, wall_points, other_wall_deg=0.0):
    """The u-turn capture (test_triage.u_turn): the largest model is the walk out and two steps
    into the turn (0-11), whose last camera is turned by edge_yaw_error_deg; 12-13 are in no
    model; the rest is another model in a frame of its own, linked by no pair. With
    wall_points, the largest model sees a wall along x at y = 3, the other a wall along x at
    y = -7 turned by other_wall_deg (in its own frame)."""
    walk = u_turn()
    placed = list(walk)
    x, y, yaw = placed[11]
    placed[11] = (x, y, yaw + edge_yaw_error_deg)
    registered = [i <= 11 for i in range(len(walk))]
    own_frame = np.array([30.0, 7.0, np.radians(137.0)])
    groups = {}
    for i in range(14, len(walk)):
        gx, gy, gyaw = poses2d.compose(own_frame, poses2d.pose(*walk[i]))
        groups[i] = {"x": gx, "y": gy, "yaw_deg": np.degrees(gyaw)}
    data = capture(walk, placed, registered, groups)
    other = {i + 1 for i in range(14, len(walk))}
    pairs = {k: v for k, v in data.pairs.items() if (k[0] in other) == (k[1] in other)}
    ground = {}
    if wall_points:
        rng = np.random.default_rng(7)
        along = rng.uniform(-1, 11, 500)
        ground[0] = np.column_stack([along, 3 + rng.normal(0, 0.02, 500)])
        turn = np.radians(other_wall_deg)
        far = np.column_stack([along * np.cos(turn), -7 + along * np.sin(turn)
                               + rng.normal(0, 0.02, 500)])
        ground[1] = np.array([poses2d.compose(own_frame, np.array([*p, 0.0]))[:2] for p in far])
    return walk, triage(TriageInput(data.scene, pairs, data.shared_points, ground_points=ground))


def _model_errors(walk, result):
    """(largest position error, largest yaw error in degrees) of the other model's proposal."""
    (run,) = [r for r in result.runs if r.image_ids[0] == 15]
    positions = [np.hypot(e.x - walk[e.image_id - 1][0], e.y - walk[e.image_id - 1][1])
                 for e in run.proposal]
    yaws = [abs((e.yaw_deg - walk[e.image_id - 1][2] + 180) % 360 - 180) for e in run.proposal]
    return max(positions), max(yaws)


def test_the_walls_turn_back_a_split_off_model_the_walk_across_the_gap_turned_wrong():
    walk, blind = split_off(8.0, wall_points=False)
    position, yaw = _model_errors(walk, blind)
    assert yaw > 15 and position > 2  # the edge camera's error, multiplied by the walk
    walk, seeing = split_off(8.0, wall_points=True)
    position, yaw = _model_errors(walk, seeing)
    assert yaw < 0.5 and position < 0.8  # turned right; the walk's start still errs


def test_a_walk_that_turned_right_stays_and_walls_far_apart_are_not_used():
    walk, blind = split_off(0.0, wall_points=False)
    assert _model_errors(walk, blind) == pytest.approx((0.0, 0.0), abs=1e-6)
    _, seeing = split_off(0.0, wall_points=True)  # as precise as the walls' direction
    assert _model_errors(walk, seeing) == pytest.approx((0.0, 0.0), abs=0.2)
    # walls 40 deg apart (modulo 90) say less than the walk: another wall, or not a square room
    _, skewed = split_off(8.0, wall_points=True, other_wall_deg=40.0)
    assert _model_errors(walk, skewed) == pytest.approx(_model_errors(walk, split_off(8.0, False)[1]))


def test_points_triangulated_far_off_are_left_out_and_every_wall_point_kept():
    rng = np.random.default_rng(9)
    walls_xy = room(10, 6, 17.0, rng)  # the walls are the outermost points: none may go
    strays = rng.uniform(1e3, 1e6, (20, 2)) * rng.choice([-1, 1], (20, 2))  # near-parallel rays
    kept = walls._without_strays(np.vstack([walls_xy, strays]))
    np.testing.assert_array_equal(kept, walls_xy)
    found = walls.wall_direction(np.vstack([walls_xy, strays]), step=0.5)
    assert found is not None and abs(walls.turn_onto(found, np.radians(17.0))) < np.radians(0.2)
