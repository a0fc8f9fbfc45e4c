"""Alignment to the truth (design.md, Evaluation): on the cameras right before the edit, else on
all cameras. A model wrong everywhere before still gets its figures."""

from guided_sfm.core import evaluation
from guided_sfm.core.truth import load_truth
from guided_sfm.core.workspace import Workspace


def test_with_fewer_than_three_reference_cameras_it_aligns_on_all(tiny_workspace_ro, tiny_sample):
    workspace, truth = Workspace(tiny_workspace_ro), load_truth(tiny_sample / "truth.json")
    on_all = evaluation.camera_status(workspace, truth)
    assert on_all.aligned_on == "all"
    status = evaluation.camera_status(workspace, truth, reference=on_all.right[:2])
    assert status.aligned_on == "all"
    assert status.wrong == on_all.wrong


def test_with_the_right_cameras_as_reference_it_aligns_on_them(tiny_workspace_ro, tiny_sample):
    workspace, truth = Workspace(tiny_workspace_ro), load_truth(tiny_sample / "truth.json")
    on_all = evaluation.camera_status(workspace, truth)
    status = evaluation.camera_status(workspace, truth, reference=on_all.right)
    assert status.aligned_on == "reference"
    assert status.wrong == on_all.wrong
    report = evaluation.evaluate_workspace(workspace, tiny_sample / "truth.json",
                                           reference_from=workspace, before_reference=[])
    assert report["aligned_on"] == "reference" and report["num_fixed"] == 0
