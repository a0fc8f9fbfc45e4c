"""Triage of a COLMAP workspace: gather what it judges from the workspace's files, then judge."""

from __future__ import annotations

from guided_sfm.core.triage import evidence
from guided_sfm.core.triage.suspects import Triage, triage
from guided_sfm.core.workspace import Workspace


def triage_workspace(workspace: Workspace) -> Triage:
    """Suspects and runs of the workspace's scene, verified pairs and largest model."""
    scene = workspace.scene()
    models = workspace.load_models()
    model, model_dir = (models[0], workspace.model_dir(0)) if models else (None, None)
    return triage(evidence.gather(scene, workspace.verified_pairs(), model, model_dir))
