"""The paper's loop end to end on the tiny rendered scene, with real pycolmap."""

from guided_sfm.demo import run_demo

from .conftest import TINY_OPTIONS


def test_one_round_fixes_the_folded_cameras(tmp_path):
    result = run_demo(layout="tiny", rounds=2, rule="paper", out_dir=tmp_path, options=TINY_OPTIONS)
    first, last = result["rounds"][0], result["rounds"][-1]
    assert first["num_wrong"] >= 3, "plain COLMAP must fold the tiny scene's far end"
    assert result["summary"]["fixed"] >= 0.9 * first["num_wrong"]
    assert last["num_models"] == 1 and last["rotation_mae_deg"] <= 3.0
    round1 = result["rounds"][1]
    assert round1["pruning"]["precision"] >= 0.8 and round1["pruning"]["recall"] >= 0.8
    assert (tmp_path / "round1" / "edits.json").is_file()
