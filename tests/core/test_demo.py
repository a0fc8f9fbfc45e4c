"""The paper's loop end to end on the tiny rendered scene, with real pycolmap."""

from statistics import fmean

import pytest

from guided_sfm.core import evaluation
from guided_sfm.core.truth import load_truth
from guided_sfm.core.workspace import Workspace
from guided_sfm.demo import pooled_pruning, run_demo

from .conftest import TINY_OPTIONS

# tiny walks a straight line: aligning on camera centres leaves the roll about that line free,
# so even cameras that were never wrong carry a few degrees (the design's definition, kept).
# The fixed cameras must be as well oriented as those, give or take this much.
MAX_ROTATION_ABOVE_FLOOR_DEG = 1.0
MAX_FLOOR_DEG = 5.0  # measured ~2-3.4 deg on tiny


def test_one_round_fixes_the_folded_cameras(tmp_path):
    result = run_demo(layout="tiny", rounds=2, rule="paper", out_dir=tmp_path, options=TINY_OPTIONS)
    first, last = result["rounds"][0], result["rounds"][-1]
    assert first["num_wrong"] >= 3, "plain COLMAP must fold the tiny scene's far end"
    assert result["summary"]["fixed"] >= 0.9 * first["num_wrong"]
    assert last["num_models"] == 1
    truth = load_truth(tmp_path / "sample" / "truth.json")
    right_before = evaluation.camera_status(Workspace(tmp_path / "round0"), truth).right
    final = evaluation.camera_status(Workspace(tmp_path / f"round{last['round']}"), truth,
                                     reference=right_before)
    assert set(first["wrong"]) <= set(final.errors), "a wrong camera ended unregistered"
    floor = fmean(final.errors[n].rotation_deg for n in right_before if n in final.errors)
    fixed = fmean(final.errors[n].rotation_deg for n in first["wrong"])
    assert floor <= MAX_FLOOR_DEG, f"the whole model is misoriented: {floor:.1f} deg"
    assert fixed <= floor + MAX_ROTATION_ABOVE_FLOOR_DEG, (fixed, floor)
    assert result["summary"]["final_rotation_mae_deg"] == pytest.approx(fixed, abs=1e-3)
    round1 = result["rounds"][1]
    assert round1["pruning"]["precision"] >= 0.8 and round1["pruning"]["recall"] >= 0.8
    assert (tmp_path / "round1" / "edits.json").is_file()


def test_pruning_is_pooled_over_the_rounds():
    def round_(deleted, true_deleted, false_pairs):
        return {"pruning": {"deleted": deleted, "true_deleted": true_deleted,
                            "false_pairs": false_pairs}}

    # recall counts against round 1's false pairs: round 2 starts from what round 1 left
    pooled = pooled_pruning([{}, round_(10, 9, 12), round_(2, 1, 3)])
    assert (pooled["deleted"], pooled["true_deleted"], pooled["false_pairs"]) == (12, 10, 12)
    assert pooled["precision"] == 10 / 12 and pooled["recall"] == 10 / 12
    assert pooled["f1"] == 10 / 12
    assert pooled_pruning([{}]) is None  # no round pruned
    nothing = pooled_pruning([{}, round_(0, 0, 0)])
    assert (nothing["precision"], nothing["recall"]) == (1.0, 1.0)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 7])
def test_one_round_repairs_the_orbit_for_either_user(tmp_path, seed):
    # Issue 20: the user who places the wrong cameras needs the checked re-map (a look-alike
    # pair with ambiguous geometry pulls a run back onto the fold), the capture-shape user who
    # re-lays every camera the both-moved two-view check (pairs of a run folded as a whole).
    # On the code before both, one round fixed 10 and 9 of seed 0's 26 wrong cameras, 1 of seed
    # 7's 27 (the default user); seed 7's capture-shape user needs the residual screen.
    for user in ("wrong", "all"):
        result = run_demo(layout="orbit", seed=seed, rounds=1, out_dir=tmp_path, reuse=True,
                          user=user)
        first, summary = result["rounds"][0], result["summary"]
        assert first["num_wrong"] >= 20, "plain COLMAP must fold the orbit"
        assert summary["fixed"] == first["num_wrong"] and summary["final_models"] == 1, user
        assert result["rounds"][1]["pruning"]["precision"] >= 0.95, user


def test_a_user_who_only_accepts_proposals_fixes_the_fold(tmp_path):
    result = run_demo(layout="tiny", rounds=1, out_dir=tmp_path, options=TINY_OPTIONS,
                      user="proposals")
    first, summary = result["rounds"][0], result["summary"]
    assert first["num_wrong"] >= 3, "plain COLMAP must fold the tiny scene's far end"
    assert summary["fixed"] == first["num_wrong"] and summary["final_models"] == 1
    assert (summary["drags"], summary["key_presses"]) == (0, 0) and summary["accepts"] >= 1
    assert summary["actions_per_fixed"] == pytest.approx(summary["accepts"] / summary["fixed"],
                                                         abs=0.01)
    assert result["rounds"][1]["actions"]["accepts"] == summary["accepts"]


@pytest.mark.slow
def test_the_split_layout_joins_with_one_group_move(tmp_path):
    # COLMAP maps the split layout as two models (nothing links its legs); the user drags the
    # second as one piece, and applying joins it (core/join_groups.py)
    result = run_demo(layout="split", rounds=1, out_dir=tmp_path, user="group")
    first, summary = result["rounds"][0], result["summary"]
    assert first["num_models"] >= 2, "COLMAP must split the layout"
    assert summary["final_models"] == 1 and summary["drags"] == first["num_models"] - 1
    assert summary["final_wrong"] == 0 and summary["fixed"] >= 0.8 * summary["initially_unregistered"]


@pytest.mark.slow
def test_the_split_layout_joins_again_after_the_re_map_when_every_camera_is_placed(
        tmp_path, monkeypatch):
    # hall-1000's round in small: the user drags the split-off leg and places every camera of
    # the largest too, so the warm start is the dragged leg alone and the largest's cameras,
    # with no match to it, are mapped as a model of their own; their placements join them
    from guided_sfm import demo
    from guided_sfm.core import simulated_user

    real_place = demo._place

    def group_and_largest(user, base, truth, targets, status, seed):
        moved, actions = real_place("group", base, truth, targets, status, seed)
        dragged = {c.image_id for c in moved}
        largest = [c.name for c in base.scene().cameras
                   if c.registered and c.image_id not in dragged and c.name in truth.cameras]
        placed = simulated_user.place_cameras(base.scene(), truth, largest,
                                              status.truth_from_model, seed)
        return moved + placed, actions

    monkeypatch.setattr(demo, "_place", group_and_largest)
    result = run_demo(layout="split", rounds=1, out_dir=tmp_path, user="group")
    first, mapped, summary = result["rounds"][0], result["rounds"][1], result["summary"]
    assert first["num_models"] >= 2, "COLMAP must split the layout"
    assert mapped["num_moved"] > first["num_registered"]  # both legs placed
    assert (mapped["map_mode"], mapped["map_fallback"]) == ("warm", None)
    assert summary["final_models"] == 1 and summary["final_wrong"] == 0
    assert mapped["num_registered"] > first["num_registered"]
