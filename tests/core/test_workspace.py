"""End to end on the tiny rendered scene: reconstruct, scene, prune into a new workspace, map."""

import json

import pytest

from guided_sfm.core.edits import parse_edits
from guided_sfm.core.errors import InvalidInput, MissingWorkspace, UnknownImage
from guided_sfm.core.sfm import RunContext, SfmOptions
from guided_sfm.core.types import CameraEdit, EditSet
from guided_sfm.core.workspace import SCENE, Workspace

from .conftest import TINY_OPTIONS


def test_reconstruct_registers_the_tiny_scene(tiny_workspace_ro, tiny_sample):
    stats = Workspace(tiny_workspace_ro).stats()
    images = len(list((tiny_sample / "images").iterdir()))
    assert stats["num_images"] == images
    assert stats["num_registered"] >= images - 1
    assert stats["num_points"] > 200
    assert (tiny_workspace_ro / "sparse" / "0" / "images.bin").is_file()


def test_scene_lists_every_image_in_capture_order(tiny_workspace_ro):
    scene = Workspace(tiny_workspace_ro).scene()
    names = [c.name for c in scene.cameras]
    assert names == sorted(names)
    assert [c.seq for c in scene.cameras] == list(range(len(names)))
    placed = [c for c in scene.cameras if c.registered]
    assert all(c.x is not None and 0 < c.fov_deg < 180 and c.range > 0 for c in placed)
    stored = json.loads((tiny_workspace_ro / SCENE).read_text())
    assert set(stored) >= {"frame", "cameras", "points", "models"}


def _far_away_edit(scene):
    """Move the last registered camera far beyond the scene, facing away from it."""
    xs = [c.x for c in scene.cameras if c.registered]
    camera = [c for c in scene.cameras if c.registered][-1]
    far = max(xs) + 50 * (max(xs) - min(xs) + 1)
    return EditSet([CameraEdit(camera.image_id, far, 0.0, 0.0)], rule="paper"), camera


def test_prune_writes_a_new_workspace_and_keeps_the_base(tiny_workspace, tmp_path):
    base = Workspace(tiny_workspace)
    edits, moved = _far_away_edit(base.scene())
    pairs_before = base.verified_pairs()
    new = Workspace(tmp_path / "next")
    outcome = base.prune(edits, new)
    involving = {p for p in pairs_before if moved.image_id in p}
    assert set(outcome.deleted) == involving and involving
    assert outcome.removed_by_test == {"frustum": len(involving)}
    assert base.verified_pairs() == pairs_before
    assert set(new.verified_pairs()) == set(pairs_before) - involving
    assert new.model_dir().is_dir() and new.edits_file.is_file()
    record = json.loads(new.pruning_file.read_text())
    assert len(record["deleted_pairs"]) == len(involving)
    assert outcome.components_after == outcome.components_before + 1


def test_map_again_after_cutting_a_camera_leaves_it_out(tiny_workspace, tmp_path):
    base = Workspace(tiny_workspace)
    scene = base.scene()
    edits, moved = _far_away_edit(scene)
    new = Workspace(tmp_path / "next")
    base.prune(edits, new)
    new.map_again(RunContext(TINY_OPTIONS), align_to=base, touched=frozenset({moved.image_id}))
    after = new.scene()
    assert not after.camera(moved.image_id).registered
    kept = [c for c in after.cameras if c.registered]
    assert len(kept) >= base.stats()["num_registered"] - 2
    # aligned to the parent: unmoved cameras stay where they were (5% of the path length)
    before = {c.image_id: c for c in scene.cameras}
    xs = [c.x for c in scene.cameras if c.registered]
    tolerance = 0.05 * (max(xs) - min(xs))
    assert all(abs(c.x - before[c.image_id].x) < tolerance for c in kept if before[c.image_id].x)


def test_unknown_image_and_missing_workspace_are_clear_errors(tiny_workspace, tmp_path):
    with pytest.raises(UnknownImage):
        parse_edits({"cameras": [{"image_id": 9999, "x": 0, "y": 0, "yaw_deg": 0}]},
                    Workspace(tiny_workspace).image_ids())
    with pytest.raises(MissingWorkspace, match="not a workspace"):
        Workspace(tmp_path / "nowhere").preview(EditSet())


@pytest.mark.parametrize(("option", "value"), [("matcher", "vocab"), ("mapper", "clustered"),
                                               ("features", "tiny"), ("camera_model", "FISHEYE")])
def test_unknown_sfm_option_names_the_choices(option, value):
    with pytest.raises(InvalidInput, match=f"unknown .*{value}.*choose one of"):
        SfmOptions(**{option: value})


def test_prune_records_the_links_it_kept_to_connect(tiny_workspace_ro, tmp_path):
    # A camera left where it is, with placement_deg far below any real residual: the placement
    # test alone would cut all its pairs; they are kept and named instead of deleted.
    scene = Workspace(tiny_workspace_ro).scene()
    camera = [c for c in scene.cameras if c.registered][5]
    edits = EditSet([CameraEdit(camera.image_id, camera.x, camera.y, camera.yaw_deg)],
                    rule="default", tolerances={"placement_deg": 0.001})
    outcome = Workspace(tiny_workspace_ro).prune(edits, Workspace(tmp_path / "next"))
    touching = {p for p in Workspace(tiny_workspace_ro).verified_pairs() if camera.image_id in p}
    assert touching and set(outcome.kept_to_connect) == touching and not outcome.deleted
    assert outcome.components_after == outcome.components_before
    record = json.loads(Workspace(tmp_path / "next").pruning_file.read_text())
    assert len(record["kept_to_connect"]) == len(touching)
    assert all(camera.name in pair for pair in record["kept_to_connect"])
