"""A re-map that splits a leg the placements joined: the placements join it again after the map
(core/join_groups.py join_placed_after_map), so the guard judges the joined result."""

import json

import numpy as np
import pycolmap
import pytest

from guided_sfm.core import geometry, remap, sfm
from guided_sfm.core.colmap_model import load_models, model_poses, to_sim3d
from guided_sfm.core.errors import EmptyModel
from guided_sfm.core.join_groups import join_placed
from guided_sfm.core.metrics import Similarity
from guided_sfm.core.types import CameraEdit
from tests.core.test_group_pose import LARGEST, OTHER, split_models
from tests.core.test_group_pose import true_placements as placements
from tests.core.test_topdown import _build, _model

WRITE_MODELS = sfm.write_models


@pytest.fixture
def scene_and_models(tmp_path):
    largest, other = split_models()
    images = [(i, n) for n, i, _, _ in LARGEST + OTHER]
    return _build([largest, other], images, tmp_path), [largest, other]


def elsewhere(cameras, turn=0.7, scale=0.5):
    """The cameras mapped alone, in a frame of their own (as COLMAP starts a new model)."""
    model = _model(cameras)
    rotation = geometry.rotations_about(np.array([0.2, 1.0, 0.4]), np.array([turn]))[0]
    model.transform(to_sim3d(Similarity(scale, rotation, np.array([-3.0, 8.0, 2.0]))))
    return model


def fake_map(warm_result, cold_result):
    """map_database answering a warm start (input_model given) and a cold map as told."""
    def map_database(database, image_dir, sparse_dir, run, input_model=None, fix_existing=False):
        result = warm_result if input_model is not None else cold_result
        if result is None:
            raise EmptyModel("mapping registered no images")
        models = [pycolmap.Reconstruction(m) for m in result]
        WRITE_MODELS(models, sparse_dir)
        return models
    return map_database


@pytest.mark.parametrize("touched_leg", ["largest", "other"])
@pytest.mark.parametrize("path", ["warm", "cold"])
def test_a_leg_the_re_map_splits_off_joins_again_by_its_placements(
        scene_and_models, tmp_path, monkeypatch, touched_leg, path):
    scene, models = scene_and_models
    everything = placements(scene.frame, LARGEST + OTHER)  # the user placed every camera
    base, joined = join_placed(models, everything, scene.frame)
    assert len(base) == 1 and base[0].num_reg_images() == len(LARGEST + OTHER)
    touched_cams, kept_cams = (LARGEST, OTHER) if touched_leg == "largest" else (OTHER, LARGEST)
    touched = {i for _, i, _, _ in touched_cams}
    # no match links the legs: the touched one is mapped as a model of its own, in its own frame
    kept = _model(kept_cams)
    split = sorted([kept, elsewhere(touched_cams)], key=lambda m: -m.num_reg_images())
    cold = sorted([elsewhere(kept_cams, 1.1, 2.0), elsewhere(touched_cams)],
                  key=lambda m: -m.num_reg_images())
    warm_result, cold_result = (split, cold) if path == "warm" else (None, cold)
    monkeypatch.setattr(sfm, "map_database", fake_map(warm_result, cold_result))
    monkeypatch.setattr(remap, "unmatched_images", lambda *args: set())  # no database
    out, report = remap.map_warm_or_cold(tmp_path / "db", tmp_path, tmp_path / "sparse", base,
                                         touched, keep_fixed=True, placements=everything,
                                         frame=scene.frame)
    assert (report.mode, report.fallback is None) == (path, path == "warm")
    assert len(out) == 1 and out[0].num_reg_images() == len(LARGEST + OTHER)
    assert len(load_models(tmp_path / "sparse")) == 1  # what was written is the joined model
    poses = model_poses(out[0])
    for _name, image_id, center, _ in touched_cams:
        np.testing.assert_allclose(poses[image_id].center, center, atol=0.15)


def test_without_placements_a_split_re_map_is_rejected_as_before(scene_and_models, tmp_path,
                                                                   monkeypatch):
    scene, models = scene_and_models
    base, _ = join_placed(models, placements(scene.frame, OTHER), scene.frame)
    split = [_model(LARGEST), elsewhere(OTHER)]
    monkeypatch.setattr(sfm, "map_database", fake_map(split, split))
    monkeypatch.setattr(remap, "unmatched_images", lambda *args: set())  # no database
    out, report = remap.map_warm_or_cold(tmp_path / "db", tmp_path, tmp_path / "sparse", base,
                                         {i for _, i, _, _ in OTHER}, keep_fixed=True)
    assert report.mode == "cold" and report.fallback is not None and len(out) == 2


def test_every_re_map_of_a_round_joins_by_the_base_frame(tiny_workspace, tmp_path, monkeypatch):
    # map_checked maps again after the first re-map rewrote scene.json in the new model's frame;
    # the placements stay in the base's
    from guided_sfm.core.sfm import RunContext
    from guided_sfm.core.types import EditSet
    from guided_sfm.core.workspace import Workspace

    from .conftest import TINY_OPTIONS

    base = Workspace(tiny_workspace)
    camera = [c for c in base.scene().cameras if c.registered][2]
    edits = EditSet([CameraEdit(camera.image_id, camera.x + 0.1, camera.y, camera.yaw_deg)],
                    rule="paper")
    new = Workspace(tmp_path / "next")
    base.prune(edits, new)
    seen, real = [], remap.map_warm_or_cold

    def recording(*args, **kwargs):
        seen.append((kwargs.get("placements"), kwargs.get("frame")))
        return real(*args, **kwargs)

    monkeypatch.setattr(remap, "map_warm_or_cold", recording)
    # a round that joined no group passes no placements: nothing is pinned at a drag
    new.map_again(RunContext(TINY_OPTIONS))
    assert seen == [(None, None)]
    # the premise: a re-map rewrites scene.json in its new model's frame, not the base's
    assert not np.allclose(new.scene().frame.origin, base.scene().frame.origin, atol=0.1)
    seen.clear()
    new = Workspace(tmp_path / "joined")
    base.prune(edits, new)
    # as join_placed_groups records a group it joined (tiny maps one model: written here)
    (new.root / "joined.json").write_text(json.dumps([camera.image_id]))

    new.map_again(RunContext(TINY_OPTIONS))
    new.map_again(RunContext(TINY_OPTIONS))
    assert len(seen) == 2
    for placed, frame in seen:
        assert placed == edits.cameras
        np.testing.assert_allclose(frame.origin, base.scene().frame.origin)
        np.testing.assert_allclose(frame.x_axis, base.scene().frame.x_axis)
    # nothing placed: nothing passed, the re-map as before
    only_pairs = Workspace(tmp_path / "pairs")
    base.prune(EditSet([], rule="paper"), only_pairs)
    only_pairs.map_again(RunContext(TINY_OPTIONS))
    assert seen[-1] == (None, None)
