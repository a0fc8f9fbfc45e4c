"""The default rule's evidence joins two lists: the database's matches name keypoints by their
index in the database, the rays and 3D points come from the model's 2D points. They agree when the
model was mapped from this database; an imported model may hold fewer 2D points (known poses only,
another extraction) and a database may name a keypoint past its list. A match must then be left
out (no verdict from it), never read another keypoint's, or another image's, ray, nor crash."""

import sqlite3

import numpy as np
import pycolmap

from guided_sfm.core import colmap_db
from guided_sfm.core.rule import evidence
from guided_sfm.core.types import CameraEdit, EditSet
from guided_sfm.core.workspace import Workspace
from tests.core.test_triage_known_poses import _without_points


def _with_first_half_of_points2d(model_dir, tmp_path):
    """Rewrite the model at model_dir with each image's first half of 2D points and no 3D points
    (poses kept): a model of another, smaller list of keypoints than the database's."""
    text = tmp_path / "half"
    text.mkdir()
    pycolmap.Reconstruction(model_dir).write_text(text)
    lines = [line for line in (text / "images.txt").read_text().splitlines() if not line.startswith("#")]
    out = []
    for pose, points in zip(lines[::2], lines[1::2], strict=True):
        xy = np.array(points.split(), dtype=float).reshape(-1, 3)[:, :2]
        half = xy[:len(xy) // 2]
        out += [pose, " ".join(f"{x} {y} -1" for x, y in half)]
    (text / "images.txt").write_text("".join(f"{line}\n" for line in out))
    (text / "points3D.txt").write_text("")
    pycolmap.Reconstruction(text).write_binary(model_dir)


def _kept_indices_within_the_models_lists(gathered):
    """Every kept match names a keypoint within its own image's list of 2D points."""
    for (a, b), rows in gathered.matches.items():
        if a in gathered.rows and b in gathered.rows:
            held = np.diff(gathered.offsets)
            assert (rows[:, 0] < held[gathered.rows[a]]).all() and (rows[:, 1] < held[gathered.rows[b]]).all()


def _moved_last_camera(workspace):
    """An edit set moving the model's last image (its keypoints come last in the evidence)."""
    camera = max((c for c in workspace.scene().cameras if c.registered), key=lambda c: c.image_id)
    return EditSet([CameraEdit(camera.image_id, camera.x + 1.0, camera.y, camera.yaw_deg)])


def test_a_model_of_known_poses_gives_no_match_evidence_and_previews(tiny_workspace, tmp_path):
    workspace = Workspace(tiny_workspace)
    _without_points(workspace.model_dir(0), tmp_path)
    pairs = list(workspace.verified_pairs())
    gathered = evidence.gather(workspace.require(), workspace.model_dir(), pairs)
    assert gathered.rows and not any(len(rows) for rows in gathered.matches.values())
    outcome = workspace.preview(_moved_last_camera(workspace))  # was an IndexError (a 500)
    assert not {"placement", "rotation"} & set(outcome.removed_by_test)  # match tests: no verdict


def test_a_model_of_fewer_points2d_than_keypoints_lends_no_ray_to_a_match(tiny_workspace, tmp_path):
    """Indices past an image's half list would read the next image's rays (misleading, no error)."""
    workspace = Workspace(tiny_workspace)
    _with_first_half_of_points2d(workspace.model_dir(0), tmp_path)
    gathered = evidence.gather(workspace.require(), workspace.model_dir(), list(workspace.verified_pairs()))
    _kept_indices_within_the_models_lists(gathered)
    workspace.preview(_moved_last_camera(workspace))


def test_a_database_naming_a_keypoint_past_its_list_loses_that_match(tiny_workspace):
    workspace = Workspace(tiny_workspace)
    pairs = workspace.verified_pairs()
    last = max(i for pair in pairs for i in pair)
    pair = max((p for p in pairs if last in p), key=pairs.get)
    with sqlite3.connect(workspace.require()) as conn:
        pair_id = pycolmap.image_pair_to_pair_id(*pair)
        n, data = conn.execute("SELECT rows, data FROM two_view_geometries WHERE pair_id = ?",
                               (pair_id,)).fetchone()
        rows = np.frombuffer(data, np.uint32).reshape(n, 2).copy()
        rows[0, pair.index(last)] = 10**6  # no image has a millionth keypoint
        conn.execute("UPDATE two_view_geometries SET data = ? WHERE pair_id = ?", (rows.tobytes(), pair_id))
    gathered = evidence.gather(workspace.require(), workspace.model_dir(), list(pairs))
    _kept_indices_within_the_models_lists(gathered)
    assert len(gathered.matches[pair]) == n - 1  # the others kept
    assert len(colmap_db.inlier_matches_of(workspace.require(), [pair])[pair]) == n
    workspace.preview(_moved_last_camera(workspace))
