"""The paper's evaluation (design.md, "Evaluation") of a workspace against a sample's truth."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from guided_sfm.core import colmap_model, metrics
from guided_sfm.core.errors import EmptyModel
from guided_sfm.core.truth import Truth, false_pairs, load_truth
from guided_sfm.core.types import pair_key
from guided_sfm.core.workspace import Workspace


@dataclass(frozen=True)
class CameraStatus:
    """Per registered camera of the largest model: its error after alignment to the truth."""

    errors: dict[str, metrics.CameraError]
    unregistered: list[str]
    num_models: int
    truth_from_model: metrics.Similarity
    aligned_on: str = "all"  # "reference": the cameras right before the edit; "all": every camera

    @property
    def wrong(self) -> list[str]:
        return sorted(name for name, bad in metrics.classify(self.errors).items() if bad)

    @property
    def right(self) -> list[str]:
        return sorted(set(self.errors) - set(self.wrong))


def camera_status(ws: Workspace, truth: Truth, reference: list[str] | None = None) -> CameraStatus:
    """Align the largest model to the truth on the reference cameras and measure every camera."""
    models = ws.load_models()
    if not models:
        raise EmptyModel(f"{ws.root} has no sparse model to evaluate")
    poses = {n: p for n, p in colmap_model.camera_poses(models[0]).items() if n in truth.cameras}
    names = sorted(set(reference or ()) & set(poses))
    # design.md: the cameras right before the edit, else all cameras (LO-RANSAC keeps it robust);
    # a model that was wrong everywhere before (a collapsed 1,000-photo hall) has none right
    aligned_on = "reference" if len(names) >= 3 else "all"
    if aligned_on == "all":
        names = sorted(poses)
    if len(names) < 3:
        raise EmptyModel(f"{ws.root}: fewer than 3 registered cameras to align with the truth")
    sim = metrics.align_similarity(np.array([poses[n][1] for n in names]),
                                   np.array([truth.cameras[n].center for n in names]))
    true_poses = {n: (c.rotation, c.center) for n, c in truth.cameras.items()}
    all_names = set(ws.image_names().values())
    return CameraStatus(metrics.camera_errors(poses, true_poses, sim),
                        sorted(all_names - set(poses)), len(models), sim, aligned_on)


def target_errors(status: CameraStatus, targets: list[str]) -> dict[str, float | None]:
    found = [status.errors[n] for n in targets if n in status.errors]
    if not found:
        return {"translation_mse": None, "rotation_mae_deg": None}
    metres = np.array([e.center for e in found])
    degrees = np.array([e.rotation_deg for e in found])
    return {"translation_mse": float(np.mean(metres**2)),
            "rotation_mae_deg": float(np.mean(degrees))}


def pruning_report(ws: Workspace, parent: Workspace, truth: Truth) -> dict | None:
    """Precision/recall/F1 of the pairs a prune deleted against the parent's false pairs."""
    if not ws.pruning_file.is_file() or truth.depth_dir is None:
        return None
    ids = parent.image_ids()
    named = json.loads(ws.pruning_file.read_text())["deleted_pairs"]
    deleted = {pair_key(ids[a], ids[b]) for a, b in named}
    false = false_pairs(parent.require(), truth)
    precision, recall, f1 = metrics.pruning_scores(deleted, false)
    return {"deleted": len(deleted), "false_pairs": len(false),
            "true_deleted": len(deleted & false), "precision": precision, "recall": recall,
            "f1": f1}


def evaluate_workspace(ws: Workspace, truth_file: Path, reference_from: Workspace | None = None,
                       before_reference: list[str] | None = None) -> dict:
    """The design's figures for a workspace; with reference_from, relative to that workspace.

    before_reference: the cameras to align reference_from on (default: all, robustly); a loop
    of rounds passes the cameras right in the round before, so "right" keeps one meaning.
    """
    truth = load_truth(truth_file)
    before = camera_status(reference_from, truth, before_reference) if reference_from else None
    status = camera_status(ws, truth, before.right if before else None)
    report: dict = {
        "num_images": len(status.errors) + len(status.unregistered),
        "num_registered": len(status.errors),
        "num_models": status.num_models,
        "aligned_on": status.aligned_on,
        "num_wrong": len(status.wrong),
        "num_unregistered": len(status.unregistered),
        "wrong": status.wrong,
        "unregistered": status.unregistered,
    }
    targets = before.wrong if before else sorted(status.errors)
    report.update(target_errors(status, targets))
    if before:
        fixed = sorted(set(before.wrong) & set(status.right))
        report.update({"num_targets": len(targets), "num_fixed": len(fixed), "fixed": fixed,
                       "still_wrong": sorted(set(before.wrong) - set(fixed)),
                       "newly_wrong": sorted(set(before.right) & set(status.wrong))})
    parent = reference_from or Workspace(ws.read_meta().get("parent", ""))
    if parent.root != Path("") and parent.database.is_file():
        report["pruning"] = pruning_report(ws, parent, truth)
    return report
