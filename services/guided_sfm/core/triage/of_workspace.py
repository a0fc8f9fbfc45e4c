"""Triage of a COLMAP workspace: gather what it judges from the workspace's files, then judge."""

from __future__ import annotations

import dataclasses

from guided_sfm.core.colmap_model import model_poses
from guided_sfm.core.triage import evidence, signals, two_view
from guided_sfm.core.triage.suspects import Triage, triage
from guided_sfm.core.types import pair_key
from guided_sfm.core.workspace import Workspace


def triage_workspace(workspace: Workspace) -> Triage:
    """Suspects and runs of the workspace's scene, verified pairs and largest model."""
    scene = workspace.scene()
    models = workspace.load_models()
    if not models:
        return triage(evidence.gather(scene, workspace.verified_pairs(), None, None))
    poses = model_poses(models[0])
    reads = evidence.read_model(workspace.model_dir(0), poses)  # once: three readers below
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
    return triage(dataclasses.replace(data, anchors=anchors, split_points=split, hops=hops))
