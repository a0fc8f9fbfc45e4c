"""Split models: group_pose beside the largest model, and joining a placed sub-model into it."""

import numpy as np
import pycolmap
import pytest

from guided_sfm.core import geometry
from guided_sfm.core.colmap_model import model_poses, to_sim3d
from guided_sfm.core.join_groups import join_placed
from guided_sfm.core.metrics import Similarity
from guided_sfm.core.types import CameraEdit, GroundFrame
from tests.core.test_topdown import _build, _model

LARGEST = [(f"a{i}.png", i + 1, (2.0 * i, 0.0, 1.5), 90.0 + 5 * (i % 2)) for i in range(5)]
OTHER = [(f"b{i}.png", i + 11, (2.0 * i + 1.0, 3.0 + 0.5 * (i % 2), 1.5), -90.0 - 4 * i)
         for i in range(4)]


def split_models():
    """The largest model in the world's frame, the other in its own (turned, tilted, scaled)."""
    largest, other = _model(LARGEST), _model(OTHER)
    tilt = geometry.rotations_about(np.array([1.0, 0.3, 0.2]), np.array([1.2]))[0]
    other.transform(to_sim3d(Similarity(0.4, tilt, np.array([5.0, -2.0, 7.0]))))
    return largest, other


@pytest.fixture
def scene_and_models(tmp_path):
    largest, other = split_models()
    images = [(i, n) for n, i, _, _ in LARGEST + OTHER]
    return _build([largest, other], images, tmp_path), [largest, other]


def test_a_sub_model_keeps_its_shape_beside_the_largest(scene_and_models):
    scene, _ = scene_and_models
    placed = [c for c in scene.cameras if c.registered]
    group = [c for c in scene.cameras if c.group_pose is not None]
    assert [c.name for c in group] == [n for n, *_ in OTHER]
    assert all((c.x, c.y, c.yaw_deg, c.center) == (None,) * 4 for c in group)  # v1 fields null
    xy = np.array([(c.group_pose["x"], c.group_pose["y"]) for c in group])
    assert xy[:, 0].min() > max(c.x for c in placed)  # set down beside, not on top
    true_xy = np.array([c[:2] for _, _, c, _ in OTHER])
    own = np.linalg.norm(xy[:, None] - xy[None], axis=2)
    truth = np.linalg.norm(true_xy[:, None] - true_xy[None], axis=2)
    # scaled to the largest model's spacing: the walks' median steps differ a little
    np.testing.assert_allclose(own / own.max(), truth / truth.max(), atol=1e-6)
    turns = np.diff([c.group_pose["yaw_deg"] for c in group])
    np.testing.assert_allclose(turns, np.diff([y for *_, y in OTHER]), atol=1e-6)


def true_placements(frame: GroundFrame, cameras=OTHER) -> list[CameraEdit]:
    """Each of these cameras (default: the other model's) where it truly is, on the frame's 2D view."""
    placements = []
    for name, image_id, center, yaw in cameras:
        x, y = frame.to_2d(np.array([center]))[0]
        rotation = _model([(name, image_id, center, yaw)]).image(image_id).cam_from_world().rotation
        placements.append(CameraEdit(image_id, float(x), float(y), float(geometry.yaw_in_frame(
            geometry.viewing_direction(rotation.matrix()), frame))))
    return placements


def tilted(frame: GroundFrame, degrees: float) -> GroundFrame:
    """The frame turned about its x axis: the ground a wall's points can suggest."""
    turn = geometry.rotations_about(frame.x_axis, np.radians([degrees]))[0]
    return GroundFrame(frame.origin, frame.x_axis, turn @ frame.y_axis, turn @ frame.up)


@pytest.mark.parametrize("tilt_deg", [0.0, 25.0])
def test_a_placed_sub_model_joins_the_largest_where_it_was_placed(scene_and_models, tilt_deg):
    scene, models = scene_and_models
    frame = tilted(scene.frame, tilt_deg)
    merged, joined = join_placed(models, true_placements(frame), frame)
    assert len(merged) == 1 and joined == {i for _, i, _, _ in OTHER}
    poses = model_poses(merged[0])
    for _name, image_id, center, _ in OTHER:
        np.testing.assert_allclose(poses[image_id].center, center, atol=0.05)
    assert merged[0].num_points3D() > models[0].num_points3D()


def test_nothing_joins_without_a_placement(scene_and_models):
    scene, models = scene_and_models
    merged, joined = join_placed(models, [CameraEdit(1, 0.0, 0.0, 90.0)], scene.frame)
    assert merged is models and joined == set()


def test_merge_keeps_image_ids_and_tracks():
    largest, other = _model(LARGEST), _model(OTHER)
    count = largest.num_points3D()
    from guided_sfm.core.join_groups import merge_into

    assert merge_into(largest, other) == len(OTHER)
    assert set(largest.reg_image_ids()) == {i for _, i, _, _ in LARGEST + OTHER}
    assert largest.num_points3D() == count + other.num_points3D()
    assert isinstance(largest, pycolmap.Reconstruction)


def test_merge_skips_the_images_the_largest_already_has():
    """Sub-models of one map may share images (COLMAP's max_model_overlap): those stay as the
    largest has them, and the other's points keep only their observations in the added images."""
    from guided_sfm.core.join_groups import merge_into

    largest, other = _model(LARGEST), _model(LARGEST[3:] + OTHER)
    before = {i: largest.image(i).cam_from_world().translation.copy() for i in largest.reg_image_ids()}
    assert merge_into(largest, other) == len(OTHER)
    assert set(largest.reg_image_ids()) == {i for _, i, _, _ in LARGEST + OTHER}
    for image_id, translation in before.items():
        np.testing.assert_allclose(largest.image(image_id).cam_from_world().translation, translation)
    added = {i for _, i, _, _ in OTHER}
    for point in largest.points3D.values():
        assert point.track.length() >= 1
    assert all(e.image_id in added or e.image_id in before
               for p in largest.points3D.values() for e in p.track.elements)


def _centers(model):
    return {i: p.center for i, p in model_poses(model).items()}


# A walk that sways (COLMAP's alignment samples 3 camera centres: a straight line is degenerate).
SWAYING = [(n, i, (c[0], 0.3 * (-1) ** i, 1.5 + 0.1 * i), y) for n, i, c, y in LARGEST]


def test_a_sub_model_sharing_images_joins_the_largest_in_its_world():
    from guided_sfm.core.join_groups import join_overlapping

    largest, other = _model(SWAYING), _model(SWAYING[2:] + OTHER)
    tilt = geometry.rotations_about(np.array([1.0, 0.3, 0.2]), np.array([1.2]))[0]
    other.transform(to_sim3d(Similarity(0.4, tilt, np.array([5.0, -2.0, 7.0]))))
    joined = join_overlapping([largest, other])
    assert len(joined) == 1
    assert set(joined[0].reg_image_ids()) == {i for _, i, _, _ in LARGEST + OTHER}
    truth = _centers(_model(SWAYING + OTHER))
    for image_id, center in _centers(joined[0]).items():
        np.testing.assert_allclose(center, truth[image_id], atol=1e-6)


def test_sub_models_sharing_too_few_images_stay_apart():
    from guided_sfm.core.join_groups import join_overlapping

    models = [_model(SWAYING), _model(SWAYING[3:] + OTHER)]  # 2 shared images
    assert join_overlapping(models, min_shared=3) is models
    assert len(join_overlapping(list(split_models()))) == 2  # nothing shared


def test_a_sub_models_points_are_carried_like_its_cameras_to_their_group_poses(scene_and_models):
    """A wall the other model sees, in its own (turned, tilted, scaled) frame, lands where the
    group poses put it: in the same place relative to its cameras as in the world."""
    from guided_sfm.core.group_pose import points_at_group_poses

    scene, models = scene_and_models
    rng = np.random.default_rng(8)
    wall = np.column_stack([rng.uniform(0, 8, 200), np.full(200, 5.0), rng.uniform(0, 3, 200)])
    tilt = geometry.rotations_about(np.array([1.0, 0.3, 0.2]), np.array([1.2]))[0]
    own_wall = Similarity(0.4, tilt, np.array([5.0, -2.0, 7.0])).apply(wall)
    group = {c.image_id: (c.group_pose["x"], c.group_pose["y"]) for c in scene.cameras
             if c.group_pose is not None}
    carried = points_at_group_poses(model_poses(models[1]), group, scene.frame, own_wall)
    # the 2D similarity taking the cameras' true ground positions onto their group poses
    true_xy = np.array([c[:2] for _, _, c, _ in OTHER])
    placed = np.array([group[i] for _, i, _, _ in OTHER])
    def complex_of(xy):
        return xy[:, 0] + 1j * xy[:, 1]

    a, b = complex_of(true_xy - true_xy.mean(0)), complex_of(placed - placed.mean(0))
    turn_and_scale = a.conj() @ b / (np.abs(a) ** 2).sum()
    expected = complex_of(wall[:, :2] - true_xy.mean(0)) * turn_and_scale
    np.testing.assert_allclose(carried, np.column_stack([expected.real, expected.imag]) + placed.mean(0),
                               atol=1e-6)
