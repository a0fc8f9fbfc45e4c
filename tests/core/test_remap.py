"""Warm re-mapping: start from the base model without the moved cameras, guarded by a cold map."""

import hashlib

import pytest

from guided_sfm.core import checked_round, remap, sfm
from guided_sfm.core.errors import Cancelled, EmptyModel
from guided_sfm.core.sfm import CancelToken, RunContext
from guided_sfm.core.types import CameraEdit, EditSet
from guided_sfm.core.workspace import Workspace

from .conftest import TINY_OPTIONS

TINY_RUN = RunContext(TINY_OPTIONS)


def _far_edit(scene):
    placed = [c for c in scene.cameras if c.registered]
    xs = [c.x for c in placed]
    return EditSet([CameraEdit(placed[-1].image_id, max(xs) + 100 * (max(xs) - min(xs)), 0, 0)],
                   rule="paper")


def _near_edit(scene):
    camera = [c for c in scene.cameras if c.registered][len(scene.cameras) // 2]
    return EditSet([CameraEdit(camera.image_id, camera.x, camera.y, camera.yaw_deg)], rule="paper")


def test_without_images_drops_the_moved_cameras_points(tiny_workspace_ro):
    model = Workspace(tiny_workspace_ro).load_models()[0]
    image_id = sorted(model.reg_image_ids())[0]
    trimmed = remap.without_images(model, {image_id})
    assert image_id not in set(trimmed.reg_image_ids())
    observations = sum(p.track.length() for p in trimmed.points3D.values())
    assert observations < sum(p.track.length() for p in model.points3D.values())
    for point in trimmed.points3D.values():
        assert image_id not in {e.image_id for e in point.track.elements}
        assert point.track.length() >= 2
    assert model.num_reg_images() == len(trimmed.reg_image_ids()) + 1  # the base is untouched


def test_warm_remap_registers_the_moved_camera_again(tiny_workspace, tmp_path):
    edits = _near_edit(Workspace(tiny_workspace).scene())
    new = Workspace(tmp_path / "next")
    Workspace(tiny_workspace).prune(edits, new)
    report = new.map_again(TINY_RUN)
    assert report.mode == "warm" and report.fallback is None
    assert report.num_registered == Workspace(tiny_workspace).stats()["num_registered"]
    assert new.scene().camera(edits.cameras[0].image_id).registered


def test_warm_remap_falls_back_to_cold_when_a_camera_cannot_return(tiny_workspace, tmp_path):
    edits = _far_edit(Workspace(tiny_workspace).scene())
    new = Workspace(tmp_path / "next")
    Workspace(tiny_workspace).prune(edits, new)
    report = new.map_again(TINY_RUN)
    assert report.mode == "cold" and "registered" in report.fallback
    assert "fell back to a cold re-map" in report.message()


def test_warm_result_is_kept_when_the_cold_fallback_does_worse(tiny_workspace, tmp_path, monkeypatch):
    # Forced here: the guard rejects the warm result and the cold map registers nothing.
    real_map = sfm.map_database

    def cold_registers_nothing(*args, input_model=None, **kwargs):
        if input_model is None:
            raise EmptyModel("mapping registered no images")
        return real_map(*args, input_model=input_model, **kwargs)

    monkeypatch.setattr(remap, "warm_result_problem", lambda *args: "forced by the test")
    monkeypatch.setattr(sfm, "map_database", cold_registers_nothing)
    edits = _near_edit(Workspace(tiny_workspace).scene())
    new = Workspace(tmp_path / "next")
    Workspace(tiny_workspace).prune(edits, new)
    report = new.map_again(TINY_RUN)
    assert report.mode == "warm" and report.fallback == "forced by the test"
    assert "cold re-map did worse still" in report.message()
    assert new.stats()["num_registered"] == Workspace(tiny_workspace).stats()["num_registered"]


def test_cancelled_warm_remap_leaves_the_workspace_untouched(tiny_workspace, tmp_path):
    edits = _near_edit(Workspace(tiny_workspace).scene())
    new = Workspace(tmp_path / "next")
    Workspace(tiny_workspace).prune(edits, new)
    digest = {p.name: hashlib.sha256(p.read_bytes()).hexdigest()
              for p in new.model_dir().iterdir()}
    token = CancelToken()

    def cancel_on_first_report(stage, fraction):
        token.cancel()

    with pytest.raises(Cancelled):
        new.map_again(RunContext(TINY_OPTIONS, cancel_on_first_report, token))
    assert digest == {p.name: hashlib.sha256(p.read_bytes()).hexdigest()
                      for p in new.model_dir().iterdir()}
    assert not (new.root / "sparse.new").exists()


class _Registered:
    """A stand-in base model: only the registered images matter to the decision."""

    def __init__(self, count: int) -> None:
        self.ids = list(range(1, count + 1))

    def reg_image_ids(self):
        return self.ids

    def num_reg_images(self):
        return len(self.ids)


@pytest.mark.parametrize(("registered", "touched", "fixed"), [
    (48, 4, True),  # few touched (<= 10%)
    (48, 25, False),  # a small project with many touched: the rest are refined (unchanged)
    (100, 50, False),  # 50 untouched: not more than a small project's capture
    (294, 137, True),  # hall-300's round: 157 untouched, a map of their own
    (294, 200, False),  # 94 untouched
])
def test_untouched_cameras_are_held_fixed_when_few_are_touched_or_many_are_not(
        registered, touched, fixed):
    assert remap.holds_untouched_fixed(_Registered(registered), set(range(1, touched + 1))) is fixed


def test_a_warm_start_leaves_out_an_untouched_camera_whose_pairs_are_all_gone(tiny_workspace,
                                                                             tmp_path):
    # The checked round's pass can delete every pair of a camera the round did not touch (a
    # camera of a sub-model its placements joined): held in the warm start's model with no match
    # left, it made pycolmap's mapper fail (unordered_map::at) and the round fell back to cold.
    base = Workspace(tiny_workspace)
    edits = _near_edit(base.scene())
    new = Workspace(tmp_path / "next")
    base.prune(edits, new)
    moved = edits.cameras[0].image_id
    lonely = next(c.image_id for c in base.scene().cameras if c.registered and c.image_id != moved)
    checked_round._delete_in_place(new, [p for p in new.verified_pairs() if lonely in p])
    report = new.map_again(TINY_RUN)
    assert report.mode == "warm" and report.fallback is None
    assert not new.scene().camera(lonely).registered
