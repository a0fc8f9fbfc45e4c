"""The user's placement as position priors: written into a real pycolmap database by a round, in
the base model's frame, with the placement's uncertainty as covariance; and used by the mapper."""

import shutil

import numpy as np
import pycolmap
import pytest

from guided_sfm.core import colmap_db, pose_prior
from guided_sfm.core.edits import parse_edits
from guided_sfm.core.sfm import RunContext, SfmOptions
from guided_sfm.core.workspace import Workspace

from .conftest import TINY_OPTIONS


def _move_one(ws: Workspace, dx: float = 1.0, dy: float = 0.5, **tolerances) -> tuple:
    scene = ws.scene()
    camera = next(c for c in scene.cameras if c.registered)
    body = {"cameras": [{"image_id": camera.image_id, "x": camera.x + dx, "y": camera.y + dy,
                         "yaw_deg": camera.yaw_deg}], "tolerances": tolerances}
    return scene, camera, parse_edits(body, ws.image_ids())


def test_a_round_writes_the_placement_in_the_base_frame(tiny_workspace, tmp_path):
    base = Workspace(tiny_workspace)
    scene, moved, edits = _move_one(base, position_share=0.2)
    new = Workspace(tmp_path / "new")
    base.prune(edits, new)
    priors = {p.image_id: p for p in colmap_db.read_position_priors(new.database)}
    registered = {c.image_id: c for c in scene.cameras if c.registered}
    assert set(priors) == set(registered)  # every registered camera, none of the others
    frame, placed = scene.frame, priors[moved.image_id]
    # on the ground: the placement's (x, y); in height: the camera's own, from its base pose
    assert frame.to_2d(placed.position[None])[0] == pytest.approx([moved.x + 1.0, moved.y + 0.5])
    height = (np.asarray(moved.center) - frame.origin) @ frame.up
    assert (placed.position - frame.origin) @ frame.up == pytest.approx(height)
    assert placed.covariance == pytest.approx((0.2 * moved.range) ** 2 * np.eye(3))
    other = next(i for i in registered if i != moved.image_id)
    assert priors[other].position == pytest.approx(np.asarray(registered[other].center))
    with pycolmap.Database.open(new.database) as database:  # as COLMAP itself reads them
        stored = next(p for p in database.read_all_pose_priors()
                      if p.corr_data_id.id == moved.image_id)
        assert stored.coordinate_system == pycolmap.PosePriorCoordinateSystem.CARTESIAN
        assert stored.corr_data_id.sensor_id.type == pycolmap.SensorType.CAMERA
        assert not np.isfinite(stored.gravity).any()  # no orientation: no gravity, no heading


def test_a_round_that_moves_nothing_leaves_no_prior(tiny_workspace, tmp_path):
    base = Workspace(tiny_workspace)
    _, _, edits = _move_one(base)
    first, second = Workspace(tmp_path / "first"), Workspace(tmp_path / "second")
    base.prune(edits, first)
    assert colmap_db.count_pose_priors(first.database) > 0
    first.prune(parse_edits({"cameras": []}, first.image_ids()), second)
    assert colmap_db.count_pose_priors(second.database) == 0  # not inherited from the parent


def test_an_unregistered_placed_camera_takes_the_median_height(tiny_workspace_ro):
    scene = Workspace(tiny_workspace_ro).scene()
    camera = next(c for c in scene.cameras if c.registered)
    stranger = max(c.image_id for c in scene.cameras) + 1
    edits = parse_edits({"cameras": [{"image_id": camera.image_id, "x": 0.0, "y": 0.0,
                                      "yaw_deg": 0.0}]}, {camera.name: camera.image_id})
    placements = {stranger: edits.cameras[0].__class__(stranger, 1.0, 2.0, 0.0)}
    priors = {p.image_id: p for p in pose_prior.placement_priors(scene, placements, 0.25)}
    heights = [(np.asarray(c.center) - scene.frame.origin) @ scene.frame.up
               for c in scene.cameras if c.registered]
    lifted = priors[stranger].position - scene.frame.origin
    assert lifted @ scene.frame.up == pytest.approx(np.median(heights))
    assert scene.frame.to_2d(priors[stranger].position[None])[0] == pytest.approx([1.0, 2.0])


def test_the_mapper_holds_the_map_to_the_priors(tiny_workspace, tmp_path):
    # A prior far off the matches' own answer, weighted strongly, pulls the camera towards it in
    # the held map and not in the free one: the mapper reads the priors we wrote. (No pruning
    # here: the rule would cut the moved camera's pairs.)
    base = Workspace(tiny_workspace)
    scene, moved, edits = _move_one(base, dx=0.5 * _spread(base.scene()), dy=0.0,
                                    position_share=0.001)
    priors = base.placement_priors(edits)
    placed = {p.image_id: p for p in priors}[moved.image_id].position
    offsets = {}
    for held in (False, True):
        new = Workspace(shutil.copytree(tiny_workspace, tmp_path / f"held-{held}"))
        colmap_db.write_position_priors(new.database, priors)
        options = SfmOptions(**{**TINY_OPTIONS.to_dict(), "placement_prior": held})
        new.map_again(RunContext(options), cold=True, align_to=base,
                      touched=frozenset({moved.image_id}))
        center = new.load_models()[0].image(moved.image_id).projection_center()
        offsets[held] = np.linalg.norm(center - placed)
    assert offsets[True] < 0.5 * offsets[False]


def _spread(scene) -> float:
    centers = np.array([c.center for c in scene.cameras if c.registered])
    return float(np.linalg.norm(centers.max(axis=0) - centers.min(axis=0)))

