"""Triage reads each model's files from its own folder. The scene numbers models largest first;
an imported workspace's folders need not be in that order (COLMAP numbers them as it made them),
so sparse/<k> is not always the k-th largest model."""

import numpy as np
import pycolmap

from guided_sfm.core import group_pose, model_files
from guided_sfm.core.colmap_model import load_models_with_dirs, model_poses
from guided_sfm.core.triage import of_workspace
from guided_sfm.core.workspace import Workspace


def _keep_only(model_dir, image_ids, target):
    """The model at model_dir with only image_ids registered, written to target."""
    model = pycolmap.Reconstruction(model_dir)
    for image_id in list(model.reg_image_ids()):
        if image_id not in image_ids:
            model.deregister_frame(model.image(image_id).frame_id)
    target.mkdir(parents=True, exist_ok=True)
    model.write_binary(target)
    return model


def test_a_sub_models_points_are_read_from_its_own_folder(tiny_workspace, monkeypatch):
    workspace = Workspace(tiny_workspace)
    full = workspace.model_dir(0)
    ids = sorted(pycolmap.Reconstruction(full).reg_image_ids())
    smaller, larger = set(ids[-6:-4]), set(ids[-4:])  # sparse/1 smaller than sparse/2
    _keep_only(full, smaller, workspace.model_dir(1))
    _keep_only(full, larger, workspace.model_dir(2))
    _keep_only(full, set(ids[:-6]), full)
    workspace.write_scene()
    seen = []
    monkeypatch.setattr(of_workspace, "triage", lambda data: seen.append(data))
    of_workspace.triage_workspace(workspace)
    (data,) = seen
    ordered = load_models_with_dirs(workspace.sparse)
    assert [d.name for d, _ in ordered] == ["0", "2", "1"]
    for index, (folder, model) in enumerate(ordered[1:], start=1):
        placed = {c.image_id: (c.group_pose["x"], c.group_pose["y"]) for c in data.scene.cameras
                  if c.model == index and c.group_pose is not None}
        assert set(placed) == set(model.reg_image_ids())
        expected = group_pose.points_at_group_poses(model_poses(model), placed, data.scene.frame,
                                                    model_files.read_points(folder)[1])
        np.testing.assert_allclose(data.ground_points[index], expected)
