"""COLMAP-shaped workspaces: reconstruct, scene, prune into a new workspace, map again, export.

A workspace holds `database.db`, `sparse/0/` (largest model), `sparse/1/`, ..., `scene.json`
(the top-down scene), `workspace.json` (where its images are, options, parent) and, when it
came from a correction round, `edits.json` and `pruning.json`. Exports are in `exports.py`.
"""

from __future__ import annotations

import json
import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pycolmap

from guided_sfm.core import colmap_db, colmap_model, match_graph, remap, sfm, topdown
from guided_sfm.core.edits import edits_to_json
from guided_sfm.core.errors import EmptyModel, MissingWorkspace
from guided_sfm.core.rule import driver as pruning
from guided_sfm.core.rule import evidence
from guided_sfm.core.rule.evidence import Evidence
from guided_sfm.core.sfm import CancelToken, SfmOptions
from guided_sfm.core.types import (
    DEFAULT_RULE,
    EditSet,
    PairKey,
    Progress,
    PruneResult,
    TopDownScene,
    no_progress,
)

DATABASE, SPARSE, SCENE, META = "database.db", "sparse", "scene.json", "workspace.json"
EDITS, PRUNING = "edits.json", "pruning.json"
# Share of a reconstruction spent in each step, so one job reports one rising fraction.
STAGE_SPANS = {"extract": (0.0, 0.2), "match": (0.2, 0.75), "map": (0.75, 1.0)}


@dataclass(frozen=True)
class PruneOutcome(PruneResult):
    """What a correction round deletes and how the match graph looks before and after."""

    components_before: int
    components_after: int


def require(workspace: Path) -> Path:
    """The workspace's database path, or a clear error when it is not a workspace."""
    database = Path(workspace) / DATABASE
    if not database.is_file():
        raise MissingWorkspace(f"{workspace} is not a workspace (no {DATABASE})")
    return database


def read_meta(workspace: Path) -> dict:
    path = Path(workspace) / META
    return json.loads(path.read_text()) if path.is_file() else {}


def write_meta(workspace: Path, meta: dict) -> None:
    (Path(workspace) / META).write_text(json.dumps(meta, indent=2))


def image_dir(workspace: Path) -> Path:
    """Where the workspace's images are (recorded when it was reconstructed)."""
    meta = read_meta(workspace)
    if "image_dir" not in meta:
        raise MissingWorkspace(f"{workspace} does not record its image directory ({META})")
    return Path(meta["image_dir"])


def spanned(progress: Progress) -> Progress:
    """A progress callback that maps each step's own fraction into the whole job's."""

    def report(stage: str, fraction: float) -> None:
        start, end = STAGE_SPANS.get(stage, (0.0, 1.0))
        progress(stage, start + (end - start) * fraction)

    return report


def reconstruct(image_dir: Path, workspace: Path, options: SfmOptions = SfmOptions(),
                progress: Progress = no_progress, cancel: CancelToken | None = None) -> None:
    """Images -> database, sparse models and scene: the first version of a project."""
    workspace = Path(workspace)
    workspace.mkdir(parents=True, exist_ok=True)
    database = workspace / DATABASE
    database.unlink(missing_ok=True)
    shutil.rmtree(workspace / SPARSE, ignore_errors=True)  # a fresh start aligns to nothing
    image_dir = Path(image_dir).resolve()
    write_meta(workspace, {"image_dir": str(image_dir), "options": options.to_dict()})
    report = spanned(progress)
    sfm.extract_features(image_dir, database, options, report, cancel)
    sfm.match_features(database, options, report, cancel)
    colmap_db.finalize(database)
    map_again(workspace, image_dir, options, report, cancel, cold=True)


def touched_images(workspace: Path) -> set[int]:
    """Images a round edited (moved cameras, members of manual deletions), from edits.json."""
    path = Path(workspace) / EDITS
    if not path.is_file():
        return set()
    edits = json.loads(path.read_text())
    return {c["image_id"] for c in edits.get("cameras", [])} | {
        i for pair in edits.get("delete_pairs", []) for i in pair}


def map_again(workspace: Path, image_dir: Path | None = None,
              options: SfmOptions = SfmOptions(), progress: Progress = no_progress,
              cancel: CancelToken | None = None, align_to: Path | None = None,
              moved: frozenset[int] | None = None, cold: bool = False) -> remap.MapReport:
    """Map the workspace's database again into its sparse/ and rebuild its scene.

    Warm (from the workspace's current model without the moved images) unless `cold` or there
    is no model. The result is aligned by a similarity on the unmoved cameras to the model it
    replaces (or to align_to's), so the view does not jump between versions.
    """
    database = require(workspace)
    images = Path(image_dir) if image_dir else globals()["image_dir"](workspace)
    moved = touched_images(workspace) if moved is None else set(moved)
    base_models = load_models(workspace)
    reference = load_models(align_to) if align_to else base_models
    staging = Path(workspace) / (SPARSE + ".new")
    try:
        models, report = remap.map_warm_or_cold(database, images, staging, base_models, moved,
                                                options, progress, cancel, cold)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)  # a cancelled or failed map leaves the base
        raise
    colmap_db.finalize(database)
    if reference and colmap_model.align_models(models, reference[0], exclude=frozenset(moved)):
        for index, model in enumerate(models):
            model.write_binary(staging / str(index))
    sparse = Path(workspace) / SPARSE
    if sparse.exists():
        shutil.rmtree(sparse)
    staging.rename(sparse)
    write_scene(workspace)
    return report


def load_models(workspace: Path) -> list[pycolmap.Reconstruction]:
    """The workspace's sparse models, largest first (empty when it was never mapped)."""
    sparse = Path(workspace) / SPARSE
    return colmap_model.load_models(sparse) if sparse.is_dir() else []


def write_scene(workspace: Path) -> TopDownScene:
    """Build the top-down scene from the models and database, and store it as scene.json."""
    database = require(workspace)
    sparse = Path(workspace) / SPARSE
    loaded = colmap_model.load_models_with_dirs(sparse) if sparse.is_dir() else []
    if not loaded:
        raise EmptyModel(f"{workspace} has no sparse model to build a scene from")
    names = colmap_db.image_names(database)
    scene = topdown.build_scene([model for _, model in loaded], loaded[0][0], sorted(names.items()),
                                colmap_db.fov_by_image(database))
    (Path(workspace) / SCENE).write_text(json.dumps(scene.to_dict()))
    return scene


def load_scene(workspace: Path) -> TopDownScene:
    """The workspace's top-down scene (built and stored on first use)."""
    path = Path(workspace) / SCENE
    if path.is_file():
        return TopDownScene.from_dict(json.loads(path.read_text()))
    return write_scene(workspace)


def image_ids(workspace: Path) -> dict[str, int]:
    """File name -> COLMAP image id."""
    return {name: image_id for image_id, name in colmap_db.image_names(require(workspace)).items()}


def verified_pairs(workspace: Path) -> dict[PairKey, int]:
    """Verified pairs of the workspace's database with their inlier counts."""
    return colmap_db.verified_pairs(require(workspace))


def preview(workspace: Path, edits: EditSet) -> PruneOutcome:
    """What pruning the workspace with these edits would delete; nothing is written."""
    pairs = verified_pairs(workspace)
    result = pruning.prune_pairs(load_scene(workspace), edits, pairs, rule_evidence(workspace, edits, pairs))
    return PruneOutcome(
        deleted=result.deleted,
        reasons=result.reasons,
        kept=result.kept,
        components_before=match_graph.count_components(pairs),
        components_after=match_graph.count_components(pairs, result.deleted),
    )


def rule_evidence(workspace: Path, edits: EditSet, pairs: dict[PairKey, int]) -> Evidence | None:
    """The default rule's evidence for the pairs of the moved cameras (None for the paper's rule)."""
    model_dir = Path(workspace) / SPARSE / "0"
    if edits.rule != DEFAULT_RULE or not edits.cameras or not model_dir.is_dir():
        return None
    touched = evidence.pairs_touching(pairs, {c.image_id for c in edits.cameras})
    return evidence.gather(require(workspace), model_dir, touched)


def prune(workspace: Path, edits: EditSet, new_workspace: Path) -> PruneOutcome:
    """Write new_workspace: the pruned database, a copy of the base models, the edits applied."""
    outcome = preview(workspace, edits)
    new_workspace = Path(new_workspace)
    if new_workspace.resolve() == Path(workspace).resolve():
        raise MissingWorkspace("the new workspace must differ from the base workspace")
    new_workspace.mkdir(parents=True, exist_ok=True)
    colmap_db.copy_without_pairs(require(workspace), new_workspace / DATABASE, outcome.deleted)
    _copy_models(workspace, new_workspace)
    meta = {**read_meta(workspace), "parent": str(Path(workspace).resolve())}
    write_meta(new_workspace, meta)
    (new_workspace / EDITS).write_text(json.dumps(edits_to_json(edits), indent=2))
    names = colmap_db.image_names(new_workspace / DATABASE)
    (new_workspace / PRUNING).write_text(json.dumps(pruning_record(outcome, names), indent=2))
    return outcome


def _copy_models(workspace: Path, new_workspace: Path) -> None:
    for name in (SPARSE, SCENE):
        source, target = Path(workspace) / name, new_workspace / name
        if target.is_dir():
            shutil.rmtree(target)
        if source.is_dir():
            shutil.copytree(source, target)
        elif source.is_file():
            shutil.copy2(source, target)


def pruning_record(outcome: PruneOutcome, names: dict[int, str]) -> dict:
    """The CLI's machine-readable summary of a prune, pairs by image name (sorted)."""
    named = sorted(sorted((names[a], names[b])) for a, b in outcome.deleted)
    return {
        "deleted_pairs": named,
        "components_before": outcome.components_before,
        "components_after": outcome.components_after,
        "removed_by_test": outcome.removed_by_test,
        "kept_to_connect": sorted(sorted((names[a], names[b])) for a, b in outcome.kept),
    }


def stats(workspace: Path) -> dict[str, int]:
    """Counts the version list shows: images, registered, models, pairs, points."""
    database = require(workspace)
    models = load_models(workspace)
    return {
        "num_images": len(colmap_db.image_names(database)),
        "num_registered": models[0].num_reg_images() if models else 0,
        "num_models": len(models),
        "num_pairs": len(colmap_db.verified_pairs(database)),
        "num_points": models[0].num_points3D() if models else 0,
    }


def compare(workspace_a: Path, workspace_b: Path) -> list[dict]:
    """Per camera of b's largest model: how far it moved and turned from a, after alignment."""
    models_a, models_b = load_models(workspace_a), load_models(workspace_b)
    if not models_a or not models_b:
        raise EmptyModel("both versions need a sparse model to be compared")
    return colmap_model.compare_models(models_a[0], models_b[0])


def scene_extent(scene: TopDownScene) -> float:
    """Largest distance between two registered camera centres (model units)."""
    centers = np.array([c.center for c in scene.cameras if c.center is not None])
    if len(centers) < 2:
        return 1.0
    return float(np.max(np.linalg.norm(centers[:, None] - centers[None], axis=2)))
