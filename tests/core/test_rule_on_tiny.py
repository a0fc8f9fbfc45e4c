"""The default rule on the reconstructed tiny scene: evidence read right, false pairs cut."""

import numpy as np
import pycolmap

from guided_sfm.core import evaluation, geometry, metrics, model_files, sfm, simulated_user
from guided_sfm.core.colmap_model import model_poses, to_sim3d
from guided_sfm.core.join_groups import join_placed
from guided_sfm.core.rule import evidence
from guided_sfm.core.topdown import scene_extent
from guided_sfm.core.truth import false_pairs, load_truth
from guided_sfm.core.types import CameraEdit, EditSet
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
    # each of the two tests that see a carried cluster finds the false pairs on its own (a pair's
    # reasons list every test that removed it): switching either off shows here
    for test in ("placement", "relative_pose"):
        by_test = {pair for pair, reasons in outcome.reasons.items() if test in reasons}
        assert len(by_test & false) >= 0.9 * len(false), (test, outcome.removed_by_test)
        assert len(by_test - false) <= 0.05 * len(by_test), (test, outcome.removed_by_test)


def a_right_camera(workspace: Workspace, truth) -> int:
    """The first registered camera (by name) the model places right, with four pairs or more, that
    left in place loses none of them (a pair with a wrong partner may go: that is the rule's job)."""
    wrong = set(evaluation.camera_status(workspace, truth).wrong)  # image names
    pairs = workspace.verified_pairs()
    for camera in sorted((c for c in workspace.scene().cameras if c.registered), key=lambda c: c.name):
        mine = [p for p in pairs if camera.image_id in p]
        if camera.name not in wrong and len(mine) >= 4 \
                and one_camera(workspace, camera.image_id)[1].deleted == []:
            return camera.image_id
    raise AssertionError("the tiny scene has no right camera that keeps its pairs in place")


def one_camera(workspace: Workspace, image_id: int, turn_deg: float = 0.0, shift: float = 0.0):
    """The default rule's preview when one camera is turned in place or carried `shift` (frame
    units, along x and y); (its verified pairs, the outcome)."""
    camera = next(c for c in workspace.scene().cameras if c.image_id == image_id)
    edit = CameraEdit(image_id, camera.x + shift, camera.y + shift, camera.yaw_deg + turn_deg)
    outcome = workspace.preview(EditSet([edit], rule="default"))
    return {p for p in workspace.verified_pairs() if image_id in p}, outcome


def test_default_rule_on_tiny_each_evidence_test_has_its_case(tiny_workspace_ro, tiny_sample):
    """Real matches, hand-made moves of a right camera (left in place, it loses no pair): turned
    90 degrees in place, the relative-rotation test removes most of its pairs and the relative-pose
    test none; carried 40% of the scene away, the relative-pose test removes them all."""
    workspace = Workspace(tiny_workspace_ro)
    image_id = a_right_camera(workspace, load_truth(tiny_sample / "truth.json"))
    pairs, _ = one_camera(workspace, image_id)
    _, turned = one_camera(workspace, image_id, turn_deg=90.0)
    # every pair goes, or is kept only to keep the camera connected (match placement alone)
    assert set(turned.deleted) | set(turned.kept_to_connect) == pairs
    assert turned.removed_by_test["rotation"] >= len(pairs) / 2, turned.removed_by_test
    assert "relative_pose" not in turned.removed_by_test  # a turn in place keeps the baseline
    _, carried = one_camera(workspace, image_id, shift=0.3 * scene_extent(workspace.scene()))
    assert set(carried.deleted) == pairs and carried.removed_by_test["relative_pose"] == len(pairs)
    assert "frustum" not in carried.removed_by_test  # every pair has evidence: no fallback


def split_off(workspace: Workspace, names: set[str]) -> None:
    """Rewrite the workspace's model as two: the named images become a model of their own, in a
    frame of its own (turned, scaled, shifted), as COLMAP starts a new model where it cannot go on."""
    model = pycolmap.Reconstruction(workspace.model_dir())
    largest, other = pycolmap.Reconstruction(model), pycolmap.Reconstruction(model)
    for image_id in model.reg_image_ids():
        image = model.image(image_id)
        (other if image.name not in names else largest).deregister_frame(image.frame_id)
    turn = geometry.rotations_about(np.array([0.3, 0.2, 1.0]), np.array([0.9]))[0]
    other.transform(to_sim3d(metrics.Similarity(0.5, turn, np.array([4.0, -3.0, 1.0]))))
    sfm.write_models([largest, other], workspace.sparse)
    workspace.write_scene()


def test_a_placed_sub_models_pairs_are_judged_by_its_own_matches(tiny_workspace, tiny_sample):
    """The folded cameras as a model of their own, placed by the simulated user: the evidence
    reads them from that model carried where the prune's join puts them, so their pairs meet the
    match tests, not the frustum test alone (whose triangles along the corridor all overlap)."""
    truth = load_truth(tiny_sample / "truth.json")
    workspace = Workspace(tiny_workspace)
    split_off(workspace, set(evaluation.camera_status(workspace, truth).wrong))
    status = evaluation.camera_status(workspace, truth)
    scene = workspace.scene()
    outside = {c.image_id for c in scene.cameras if not c.registered}
    assert len(outside) == 5 and len(workspace.load_models()) == 2
    edits = EditSet(simulated_user.place_cameras(scene, truth, status.unregistered,
                                                 status.truth_from_model, seed=1), rule="default")
    pairs = workspace.verified_pairs()
    gathered = workspace.rule_evidence(edits, pairs)
    assert outside <= set(gathered.rows)
    joined = model_poses(join_placed(workspace.load_models(), edits.cameras, scene.frame)[0][0])
    for image_id in outside:  # where the prune's join puts them
        row = gathered.rows[image_id]
        np.testing.assert_allclose(gathered.rotations[row], joined[image_id].rotation, atol=1e-9)
        np.testing.assert_allclose(gathered.translations[row], joined[image_id].translation,
                                   atol=1e-9)
    outcome = workspace.preview(edits)
    false = {p for p in false_pairs(workspace.require(), truth) if set(p) & outside}
    precision, recall, _ = metrics.pruning_scores(set(outcome.deleted), false)
    assert false and precision >= 0.95 and recall >= 0.9
    assert "frustum" not in outcome.removed_by_test
