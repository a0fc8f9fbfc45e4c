"""Triage of an imported workspace whose model holds fewer 2D points per image than its database
has keypoints (a model of known poses: images.txt with empty POINTS2D lines, no 3D points)."""

import pycolmap

from guided_sfm.core.triage.of_workspace import triage_workspace
from guided_sfm.core.workspace import Workspace


def _without_points(model_dir, tmp_path):
    """Rewrite the binary model at model_dir with its poses only."""
    text = tmp_path / "text"
    text.mkdir()
    pycolmap.Reconstruction(model_dir).write_text(text)
    lines = (text / "images.txt").read_text().splitlines()
    header = [line for line in lines if line.startswith("#")]
    poses = [line for line in lines if not line.startswith("#")][::2]
    (text / "images.txt").write_text("".join(f"{line}\n" for line in header)
                                      + "".join(f"{pose}\n\n" for pose in poses))
    (text / "points3D.txt").write_text("")
    model = pycolmap.Reconstruction(text)
    assert model.num_reg_images() and not model.num_points3D()
    model.write_binary(model_dir)


def test_a_model_of_known_poses_is_triaged_without_its_matches_points(tiny_workspace, tmp_path):
    workspace = Workspace(tiny_workspace)
    _without_points(workspace.model_dir(0), tmp_path)
    result = triage_workspace(workspace)  # was an IndexError (a 500 at GET .../suspects)
    registered = set(pycolmap.Reconstruction(workspace.model_dir(0)).reg_image_ids())
    assert {s.image_id for s in result.suspects} == registered
