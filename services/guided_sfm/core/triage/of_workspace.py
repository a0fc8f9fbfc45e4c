"""Triage of a COLMAP workspace: gather what it judges from the workspace's files, then judge."""

from __future__ import annotations

import dataclasses

import numpy as np

from guided_sfm.core import group_pose, model_files
from guided_sfm.core.colmap_model import model_poses
from guided_sfm.core.triage import evidence, signals, two_view
from guided_sfm.core.triage.suspects import Triage, triage
from guided_sfm.core.types import TopDownScene, pair_key
from guided_sfm.core.workspace import Workspace


def triage_workspace(workspace: Workspace) -> Triage:
    """Suspects and runs of the workspace's scene, verified pairs and largest model."""
    scene = workspace.scene()
    loaded = workspace.load_models_with_dirs()  # sparse/<k> is not always the k-th largest
    if not loaded:
        return triage(evidence.gather(scene, workspace.verified_pairs(), None, None))
    models = [model for _, model in loaded]
    poses = model_poses(models[0])
    reads = evidence.read_model(loaded[0][0], poses)  # once: three readers below
    data = evidence.gather(scene, workspace.verified_pairs(), models[0], reads)
    cameras = sorted(scene.cameras, key=lambda c: c.seq)
    share = signals.typical_share(cameras, data.pairs, data.shared_points)
    conflicts = [key for key, n in data.pairs.items() if key in data.shared_points
                 and signals.is_conflict(n, data.shared_points[key], share)]
    anchors = two_view.anchors_of(workspace.require(), models[0], scene.frame, conflicts)
    split = evidence.split_points(workspace.require(), reads, scene.frame, data.pairs, data.shared_points)
    broken = [pair_key(s.before.image_id, s.after.image_id)
              for s in signals.steps_between(cameras, data.pairs, data.shared_points) if s.breaks]
    hops = two_view.hops_of(workspace.require(), models[0], reads, scene.frame, broken)
    return triage(dataclasses.replace(data, anchors=anchors, split_points=split, hops=hops,
                                      ground_points=_ground_points(scene, loaded, poses, reads)))


def _ground_points(scene: TopDownScene, loaded: list, poses: dict,
                   reads: evidence.ModelReads) -> dict[int, np.ndarray]:
    """Per model, its 3D points on the ground plane where the scene shows its cameras (the
    largest's as placed, another's at its group poses); none with one model (only another
    model's placement reads them)."""
    if len(loaded) < 2:
        return {}
    out = {0: group_pose.upright_points(poses, scene.frame, reads.points[1])}
    for index, (folder, model) in enumerate(loaded[1:], start=1):
        placed = {c.image_id: (c.group_pose["x"], c.group_pose["y"]) for c in scene.cameras
                  if c.model == index and c.group_pose is not None}
        out[index] = group_pose.points_at_group_poses(
            model_poses(model), placed, scene.frame, model_files.read_points(folder)[1])
    return out
