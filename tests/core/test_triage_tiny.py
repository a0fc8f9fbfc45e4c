"""Triage on a real reconstruction: the tiny sample folds its last five views back onto the
first ones; triage must raise exactly the cameras wrong against the truth and propose them near it."""

import numpy as np
import pycolmap
import pytest

from guided_sfm.core import evaluation, simulated_user
from guided_sfm.core.sfm import RunContext
from guided_sfm.core.triage.of_workspace import triage_workspace
from guided_sfm.core.triage.suspects import RAISE_SCORE
from guided_sfm.core.truth import load_truth
from guided_sfm.core.workspace import Workspace
from guided_sfm.sample import write_sample
from tests.core.conftest import TINY_OPTIONS

NEAR_M, NEAR_DEG = 0.5, 15.0  # the simulated user's own error is 0.3 m and 10 deg


def test_tiny_suspects_are_the_wrong_cameras_and_proposals_land_near_the_truth(tiny_workspace_ro,
                                                                              tiny_sample):
    workspace = Workspace(tiny_workspace_ro)
    truth = load_truth(tiny_sample / "truth.json")
    status = evaluation.camera_status(workspace, truth)
    assert status.wrong, "the tiny sample is expected to fold"
    result = triage_workspace(workspace)
    names = workspace.image_names()
    assert {names[s.image_id] for s in result.suspects if s.score >= RAISE_SCORE} == set(status.wrong)
    proposed = [c for run in result.runs for c in run.proposal]
    assert {names[c.image_id] for c in proposed} == set(status.wrong)
    scene, sim = workspace.scene(), status.truth_from_model
    for edit in proposed:
        x, y, yaw = simulated_user._true_pose_2d(scene, truth, names[edit.image_id], sim)
        assert np.hypot(edit.x - x, edit.y - y) * sim.scale < NEAR_M
        assert abs((edit.yaw_deg - yaw + 180) % 360 - 180) < NEAR_DEG


@pytest.mark.slow
def test_a_rendering_colmap_gets_right_raises_nothing(tmp_path):
    sample = write_sample(tmp_path / "sample", "tiny", seed=1)  # tiny does not fold with seed 1
    pycolmap.set_random_seed(0)
    workspace = Workspace(tmp_path / "ws")
    workspace.reconstruct(sample / "images", RunContext(TINY_OPTIONS))
    assert not evaluation.camera_status(workspace, load_truth(sample / "truth.json")).wrong
    result = triage_workspace(workspace)
    assert max(s.score for s in result.suspects) < RAISE_SCORE and result.runs == []
