"""The default rule on the reconstructed tiny scene: evidence read right, false pairs cut."""

import numpy as np
import pycolmap

from guided_sfm.core import evaluation, metrics, model_files, simulated_user
from guided_sfm.core.rule import evidence
from guided_sfm.core.truth import false_pairs, load_truth
from guided_sfm.core.types import EditSet
from guided_sfm.core.workspace import Workspace


def test_model_files_agree_with_pycolmap(tiny_workspace_ro):
    model_dir = tiny_workspace_ro / "sparse" / "0"
    model = pycolmap.Reconstruction(model_dir)
    image_id = model.reg_image_ids()[0]
    xy, point_ids = model_files.read_observations(model_dir, [image_id])[image_id]
    expected = model.image(image_id).points2D
    assert np.allclose(xy, [p.xy for p in expected])
    assert [int(i) for i in point_ids if i >= 0] == [p.point3D_id for p in expected if p.has_point3D()]
    ids, xyz = model_files.read_points(model_dir)
    assert len(ids) == model.num_points3D()
    assert np.allclose(xyz[np.searchsorted(ids, ids[5])], model.point3D(int(ids[5])).xyz)


def test_evidence_rays_and_points_of_a_registered_image(tiny_workspace_ro):
    workspace = Workspace(tiny_workspace_ro)
    pairs = workspace.verified_pairs()
    gathered = evidence.gather(workspace.require(), workspace.model_dir(), list(pairs)[:5])
    assert np.allclose(np.linalg.norm(gathered.rays, axis=1), 1.0)
    row = 0
    keypoints = slice(gathered.offsets[row], gathered.offsets[row + 1])
    seen = gathered.points[keypoints]
    seen = seen[~np.isnan(seen[:, 0])]
    in_camera = seen @ gathered.rotations[row].T + gathered.translations[row]
    rays = in_camera / np.linalg.norm(in_camera, axis=1, keepdims=True)
    assert len(seen) > 20 and (in_camera[:, 2] > 0).all()
    observed = gathered.rays[keypoints][~np.isnan(gathered.points[keypoints][:, 0])]
    assert np.median(np.degrees(np.arccos(np.clip((rays * observed).sum(1), -1, 1)))) < 0.5


def test_default_rule_cuts_the_tiny_scenes_false_pairs(tiny_workspace_ro, tiny_sample):
    truth = load_truth(tiny_sample / "truth.json")
    workspace = Workspace(tiny_workspace_ro)
    status = evaluation.camera_status(workspace, truth)
    scene = workspace.scene()
    edits = EditSet(simulated_user.place_cameras(scene, truth, status.wrong, status.truth_from_model,
                                                 seed=1), rule="default")
    outcome = workspace.preview(edits)
    moved = {e.image_id for e in edits.cameras}
    false = {p for p in false_pairs(workspace.require(), truth) if set(p) & moved}
    assert status.wrong and false, "the tiny scene is expected to fold (see test_sample.py)"
    precision, recall, _ = metrics.pruning_scores(set(outcome.deleted), false)
    assert precision >= 0.95 and recall >= 0.9
    assert set(outcome.removed_by_test) <= {"placement", "relative_pose", "rotation", "frustum"}
    assert outcome.components_after == outcome.components_before
