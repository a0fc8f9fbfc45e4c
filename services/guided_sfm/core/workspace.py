"""COLMAP-shaped workspaces (cf. OpenSfM's DataSet): one object owns a folder's layout, reads and
writes its files, and runs the steps on it: reconstruct, preview and prune an edit set into a new
workspace, map again.

A workspace holds `database.db`, `sparse/0/` (largest model), `sparse/1/`, ..., `scene.json`
(the top-down scene), `workspace.json` (where its images are, options, the matcher, mapper
and image size used, parent), `vocab_tree.bin` when retrieval matched it (kept: later runs
reuse it) and, when it came from a correction round, `edits.json` and `pruning.json`. Exports
are in `exports.py`.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import pycolmap

from guided_sfm.core import (
    colmap_db,
    colmap_model,
    join_groups,
    match_graph,
    metrics,
    pose_prior,
    remap,
    retrieval,
    sfm,
    topdown,
)
from guided_sfm.core.edits import edits_to_json
from guided_sfm.core.errors import EmptyModel, MissingWorkspace
from guided_sfm.core.rule import driver, evidence, separates
from guided_sfm.core.rule.evidence import Evidence
from guided_sfm.core.rule.tolerances import Tolerances
from guided_sfm.core.sfm import RunContext
from guided_sfm.core.types import (
    DEFAULT_RULE,
    CameraEdit,
    EditSet,
    GroundFrame,
    PairKey,
    Progress,
    PruneResult,
    TopDownScene,
)

DATABASE, SPARSE, SCENE, META = "database.db", "sparse", "scene.json", "workspace.json"
EDITS, PRUNING, JOINED = "edits.json", "pruning.json", "joined.json"
# Share of a reconstruction spent in each step, so one job reports one rising fraction.
STAGE_SPANS = {"extract": (0.0, 0.2), "match": (0.2, 0.75), "map": (0.75, 1.0)}


@dataclass(frozen=True)
class PruneOutcome(PruneResult):
    """What a correction round deletes and how the match graph looks before and after."""

    components_before: int
    components_after: int


def spanned(progress: Progress) -> Progress:
    """A progress callback that maps each step's own fraction into the whole job's."""

    def report(stage: str, fraction: float) -> None:
        start, end = STAGE_SPANS.get(stage, (0.0, 1.0))
        progress(stage, start + (end - start) * fraction)

    return report


class Workspace:
    """One workspace folder: the paths of its files, what they hold, and the steps run on it."""

    def __init__(self, root: Path | str) -> None:
        self.root = Path(root)
        self.database, self.sparse = self.root / DATABASE, self.root / SPARSE
        self.scene_file, self.meta_file = self.root / SCENE, self.root / META
        self.edits_file, self.pruning_file = self.root / EDITS, self.root / PRUNING
        self.tree = self.root / retrieval.TREE_FILE

    def __repr__(self) -> str:
        return f"Workspace({str(self.root)!r})"

    def model_dir(self, index: int = 0) -> Path:
        """sparse/<index>: 0 is the largest model."""
        return self.sparse / str(index)

    # -- reading and writing its files ------------------------------------------------------------

    def require(self) -> Path:
        """The database's path, or a clear error when this is not a workspace."""
        if not self.database.is_file():
            raise MissingWorkspace(f"{self.root} is not a workspace (no {DATABASE})")
        return self.database

    def read_meta(self) -> dict:
        return json.loads(self.meta_file.read_text()) if self.meta_file.is_file() else {}

    def write_meta(self, meta: dict) -> None:
        self.meta_file.write_text(json.dumps(meta, indent=2))

    def image_dir(self) -> Path:
        """Where the workspace's images are (recorded when it was reconstructed)."""
        meta = self.read_meta()
        if "image_dir" not in meta:
            raise MissingWorkspace(f"{self.root} does not record its image directory ({META})")
        return Path(meta["image_dir"])

    def image_names(self) -> dict[int, str]:
        """COLMAP image id -> file name."""
        return colmap_db.image_names(self.require())

    def image_ids(self) -> dict[str, int]:
        """File name -> COLMAP image id."""
        return {name: image_id for image_id, name in self.image_names().items()}

    def verified_pairs(self) -> dict[PairKey, int]:
        """Verified pairs of the workspace's database with their inlier counts."""
        return colmap_db.verified_pairs(self.require())

    def load_models(self) -> list[pycolmap.Reconstruction]:
        """The sparse models, largest first (empty when it was never mapped)."""
        return [model for _, model in self.load_models_with_dirs()]

    def load_models_with_dirs(self) -> list[tuple[Path, pycolmap.Reconstruction]]:
        """(folder, model) of the sparse models, largest first: an imported workspace's folders
        need not be numbered in that order."""
        return colmap_model.load_models_with_dirs(self.sparse) if self.sparse.is_dir() else []

    def number_models_largest_first(self) -> None:
        """Rename the sparse/<k> folders so that 0 is the largest model, 1 the next, ..., as
        reconstruct writes them (an imported workspace's are numbered as COLMAP made them); every
        reader of sparse/0 then reads the largest. Equal models keep their order."""
        loaded = self.load_models_with_dirs()
        if [folder.name for folder, _ in loaded] == [str(k) for k in range(len(loaded))]:
            return
        moving = [folder.rename(folder.with_name(folder.name + ".renumbered")) for folder, _ in loaded]
        for index, folder in enumerate(moving):
            folder.rename(self.model_dir(index))

    def build_scene(self) -> TopDownScene:
        """The top-down scene built from the models and database (nothing written)."""
        database = self.require()
        loaded = self.load_models_with_dirs()
        if not loaded:
            raise EmptyModel(f"{self.root} has no sparse model to build a scene from")
        return topdown.build_scene([model for _, model in loaded], loaded[0][0],
                                   sorted(self.image_names().items()),
                                   colmap_db.fov_by_image(database))

    def write_scene(self) -> TopDownScene:
        """Build the top-down scene and store it as scene.json."""
        scene = self.build_scene()
        self.scene_file.write_text(json.dumps(scene.to_dict()))
        return scene

    def scene(self) -> TopDownScene:
        """The workspace's top-down scene (built and stored on first use)."""
        if self.scene_file.is_file():
            return TopDownScene.from_dict(json.loads(self.scene_file.read_text()))
        return self.write_scene()

    def touched_images(self) -> set[int]:
        """Images the round that made this workspace edited (placed cameras and members of manual
        deletions), from edits.json; empty when no round made it."""
        if not self.edits_file.is_file():
            return set()
        edits = json.loads(self.edits_file.read_text())
        # cameras of a sub-model joined by their placement keep the pose it gave them
        joined_file = self.root / JOINED
        joined = set(json.loads(joined_file.read_text())) if joined_file.is_file() else set()
        return ({c["image_id"] for c in edits.get("cameras", [])} - joined) | {
            i for pair in edits.get("delete_pairs", []) for i in pair}

    def stats(self) -> dict[str, int]:
        """Counts the version list shows: images, registered, models, pairs, points."""
        database = self.require()
        models = self.load_models()
        return {
            "num_images": len(colmap_db.image_names(database)),
            "num_registered": models[0].num_reg_images() if models else 0,
            "num_models": len(models),
            "num_pairs": len(colmap_db.verified_pairs(database)),
            "num_points": models[0].num_points3D() if models else 0,
        }

    # -- steps ------------------------------------------------------------------------------------

    def reconstruct(self, image_dir: Path, run: RunContext = RunContext(),
                    image_names: Sequence[str] | None = None) -> None:
        """Images (all of the folder's, or those named) -> database, sparse models and scene: the
        first version of a project."""
        self.root.mkdir(parents=True, exist_ok=True)
        self.database.unlink(missing_ok=True)
        shutil.rmtree(self.sparse, ignore_errors=True)  # a fresh start aligns to nothing
        image_dir = Path(image_dir).resolve()
        meta = {"image_dir": str(image_dir), "options": run.options.to_dict()}
        self.write_meta(meta)
        run = run.reporting_to(spanned(run.progress))
        sfm.extract_features(image_dir, self.database, run, image_names)
        # the tree, if any, stays: a tree of the same project's images serves a new run as well
        meta["used"] = {"matcher": sfm.match_features(self.database, run, self.tree),
                        "mapper": run.options.mapper,
                        "pairs": colmap_db.matched_pair_count(self.database),
                        "max_image_size": sfm.effective_max_image_size(run.options)}
        self.write_meta(meta)
        colmap_db.finalize(self.database)
        self.map_again(run, image_dir, cold=True)

    def used(self) -> dict[str, str | int]:
        """The matcher and mapper the reconstruction used (what `auto` chose), how many pairs it
        matched and the longest image side SIFT ran at; {} if unknown."""
        return dict(self.read_meta().get("used", {}))

    def map_again(self, run: RunContext = RunContext(), image_dir: Path | None = None,
                  align_to: Workspace | None = None, touched: frozenset[int] | None = None,
                  cold: bool = False) -> remap.MapReport:
        """Map the database again into sparse/ and rebuild the scene.

        Warm (from the current model without the touched images, by default those of
        edits.json) unless `cold` or there is no model. The result is aligned by a similarity on
        the other cameras to the model it replaces (or to align_to's), so the view does not jump
        between versions.
        """
        database = self.require()
        touched = self.touched_images() if touched is None else set(touched)
        base_models = self.load_models()
        reference = align_to.load_models() if align_to else base_models
        staging = self.root / (SPARSE + ".new")
        try:
            models, report = remap.map_warm_or_cold(database, image_dir or self.image_dir(), staging,
                                                    base_models, touched, run, cold,
                                                    keep_fixed=(self.root / JOINED).is_file(),
                                                    **self._placed(base_models))
        except BaseException:
            shutil.rmtree(staging, ignore_errors=True)  # a cancelled or failed map leaves the base
            raise
        colmap_db.finalize(database)
        if reference and colmap_model.align_models(models, reference[0], exclude=frozenset(touched)):
            for index, model in enumerate(models):
                model.write_binary(staging / str(index))
        if self.sparse.exists():
            shutil.rmtree(self.sparse)
        staging.rename(self.sparse)
        self.write_scene()
        return report

    def _placed(self, base_models: list) -> dict:
        """The round's placements and the base's scene frame they are in (edits.json), for the
        re-map to join what the matches cannot; {} when none (or an edits.json from before the
        frame was recorded). Not this workspace's scene.json: a re-map rewrites it in the frame
        of the new model, and map_checked maps again. Only a round that joined a group before
        the map (joined.json) joins after it: in any other round a camera the re-map cannot
        register with the rest is left to the guard, not pinned where the user dragged it."""
        if not base_models or not self.edits_file.is_file() or not (self.root / JOINED).is_file():
            return {}
        edits = json.loads(self.edits_file.read_text())
        cameras = edits.get("cameras", [])
        if not cameras or "frame" not in edits:
            return {}
        return {"placements": [CameraEdit(c["image_id"], c["x"], c["y"], c["yaw_deg"])
                               for c in cameras],
                "frame": GroundFrame.from_dict(edits["frame"])}

    def preview(self, edits: EditSet) -> PruneOutcome:
        """What pruning this workspace with these edits would delete; nothing is written."""
        pairs = self.verified_pairs()
        result = driver.prune_pairs(self.scene(), edits, pairs, self.rule_evidence(edits, pairs))
        return PruneOutcome(
            deleted=result.deleted,
            reasons=result.reasons,
            kept_to_connect=result.kept_to_connect,
            components_before=match_graph.count_components(pairs),
            components_after=match_graph.count_components(pairs, result.deleted),
        )

    def rule_evidence(self, edits: EditSet, pairs: dict[PairKey, int]) -> Evidence | None:
        """The default rule's evidence for the pairs of the placed cameras (None for the paper's
        rule, which needs none)."""
        if edits.rule != DEFAULT_RULE or not edits.cameras or not self.model_dir().is_dir():
            return None
        needed = separates.partners_of_moved(pairs, {c.image_id for c in edits.cameras})
        return evidence.gather(self.require(), self.model_dir(), needed,
                               self.placed_sub_models(edits))

    def placed_sub_models(self, edits: EditSet) -> list[tuple[Path, metrics.Similarity]]:
        """The sub-models the edit set's placements join (join_placed_groups), each with the
        similarity carrying it into the largest model's world, largest first."""
        largest = self.model_dir()
        others = [d for d in self.sparse.iterdir() if d.name.isdigit() and d != largest]
        in_largest = evidence.model_parts(largest).poses
        if not others or all(c.image_id in in_largest for c in edits.cameras):
            return []  # (a sub-model is read only when the edit set places one of its cameras)
        parts = {d: evidence.model_parts(d).poses for d in others}
        others.sort(key=lambda d: (-len(parts[d]), int(d.name)))
        found = join_groups.placed_similarities([in_largest, *(parts[d] for d in others)],
                                                edits.cameras, self.scene().frame)
        return [(others[index - 1], sim) for index, sim in sorted(found.items())]

    def prune(self, edits: EditSet, new: Workspace) -> PruneOutcome:
        """Write the new workspace: the pruned database, a copy of the base models, the edits
        applied and the record of what was deleted."""
        outcome = self.preview(edits)
        if new.root.resolve() == self.root.resolve():
            raise MissingWorkspace("the new workspace must differ from the base workspace")
        new.root.mkdir(parents=True, exist_ok=True)
        colmap_db.copy_without_pairs(self.require(), new.database, outcome.deleted)
        colmap_db.write_position_priors(new.database, self.placement_priors(edits))
        self._copy_models_to(new)
        frame = self.scene().frame
        new.join_placed_groups(edits, frame)
        new.write_meta({**self.read_meta(), "parent": str(self.root.resolve())})
        # the frame the placements are in, for the re-map's join (_placed)
        edits_record = edits_to_json(edits)
        if edits.cameras:
            edits_record["frame"] = frame.to_dict()
        new.edits_file.write_text(json.dumps(edits_record, indent=2))
        record = pruning_record(outcome, new.image_names())
        new.pruning_file.write_text(json.dumps(record, indent=2))
        return outcome

    def placement_priors(self, edits: EditSet) -> list[pose_prior.PositionPrior]:
        """The position priors an edit set gives the re-map, in this workspace's model frame
        (core/pose_prior.py); none when it moves no camera (a round that only prunes)."""
        if not edits.cameras or not self.model_dir().is_dir():
            return []
        share = Tolerances(**edits.tolerances).position_share
        placements = {placement.image_id: placement for placement in edits.cameras}
        return pose_prior.placement_priors(self.scene(), placements, share)

    def join_placed_groups(self, edits: EditSet, frame) -> set[int]:
        """Merge the sub-models the edit set places into the largest (core/join_groups.py),
        rewriting sparse/ and recording the joined images in joined.json."""
        models = self.load_models()
        merged, joined = join_groups.join_placed(models, edits.cameras, frame)
        (self.root / JOINED).unlink(missing_ok=True)  # a workspace pruned into again
        if joined:
            shutil.rmtree(self.sparse)
            sfm.write_models(merged, self.sparse)
            (self.root / JOINED).write_text(json.dumps(sorted(joined)))
        return joined

    def _copy_models_to(self, new: Workspace) -> None:
        for source, target in ((self.sparse, new.sparse), (self.scene_file, new.scene_file)):
            if target.is_dir():
                shutil.rmtree(target)
            if source.is_dir():
                shutil.copytree(source, target)
            elif source.is_file():
                shutil.copy2(source, target)

    def compare(self, other: Workspace, edited: set[str] = frozenset()) -> list[dict]:
        """Per camera of the other's largest model: how far it moved and turned from this one's,
        after alignment on the cameras not named in `edited` (those an edit between them moved)."""
        models_a, models_b = self.load_models(), other.load_models()
        if not models_a or not models_b:
            raise EmptyModel("both versions need a sparse model to be compared")
        return colmap_model.compare_models(models_a[0], models_b[0], edited)

    def touched_names(self) -> set[str]:
        """touched_images by image name."""
        names = self.image_names()
        return {names[i] for i in self.touched_images() if i in names}


def pruning_record(outcome: PruneOutcome, names: dict[int, str]) -> dict:
    """The CLI's machine-readable summary of a prune, pairs by image name (sorted)."""
    named = sorted(sorted((names[a], names[b])) for a, b in outcome.deleted)
    return {
        "deleted_pairs": named,
        "components_before": outcome.components_before,
        "components_after": outcome.components_after,
        "removed_by_test": outcome.removed_by_test,
        "kept_to_connect": sorted(sorted((names[a], names[b])) for a, b in outcome.kept_to_connect),
    }
