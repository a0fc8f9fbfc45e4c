"""Warm re-mapping: continue from the previous model without the touched images (those the round
edited), guarded by a cold re-map when the warm result looks worse than where it started."""

from __future__ import annotations

import logging
import tempfile
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import pycolmap

from guided_sfm.core import colmap_db, join_groups, sfm
from guided_sfm.core.errors import EmptyModel
from guided_sfm.core.sfm import RunContext
from guided_sfm.core.types import CameraEdit, GroundFrame

log = logging.getLogger(__name__)

# Keeping the untouched cameras fixed is what makes a warm start fast; when many are touched,
# the rest were likely bent by the same false matches, so they are refined too.
FIX_EXISTING_SHARE = 0.1
# ... unless the untouched are more than a small project's whole capture: then they are a map of
# their own that the edit did not question. On hall-300's round (137 of 294 placed) refining
# them let the re-registered leg pull them back into the fold in 2 of 3 runs (40, 41, 137 of
# 137 fixed); held fixed, 137 in all 5 runs, with 2-3x less CPU (docs/engine.md "Edits at
# 1,000 cameras").
# Small projects (<= 100 images) never reach it: their path is unchanged.
FIX_EXISTING_ABOVE_UNTOUCHED = sfm.LARGE_MAP_ABOVE_IMAGES
# The warm result is rejected when its mean reprojection error grows beyond both of these.
MAX_ERROR_RATIO, MAX_ERROR_GAIN_PX = 1.5, 0.5


@dataclass(frozen=True)
class MapReport:
    """How a workspace was mapped: warm or cold, why a warm start fell back, how long it took."""

    mode: str  # the result kept: "warm" or "cold"
    fallback: str | None  # why the warm result failed its guard (a cold re-map was then tried)
    seconds: float
    num_registered: int
    num_models: int

    def message(self) -> str:
        text = f"{self.mode} re-map: {self.num_registered} images in {self.num_models} model(s)"
        if self.fallback and self.mode == "cold":
            text += f"; the warm start fell back to a cold re-map ({self.fallback})"
        elif self.fallback:
            text += (f"; the warm result looked worse than its base ({self.fallback}), "
                     "but a cold re-map did worse still")
        return text


def without_images(model: pycolmap.Reconstruction, image_ids: set[int]) -> pycolmap.Reconstruction:
    """A copy of the model with those images de-registered and their lone points dropped."""
    trimmed = pycolmap.Reconstruction(model)
    observations = pycolmap.ObservationManager(trimmed)
    for image_id in sorted(image_ids):
        if trimmed.exists_image(image_id) and trimmed.image(image_id).has_pose:
            observations.deregister_frame(trimmed.image(image_id).frame_id)
    return trimmed


def unmatched_images(database: Path, model: pycolmap.Reconstruction) -> set[int]:
    """The model's images with no verified pair left in the database. A check pass can delete
    every pair of a camera the round did not touch (one a placement joined); held in a warm
    start's model with no match, it makes pycolmap's mapper fail (unordered_map::at)."""
    matched = {i for pair in colmap_db.verified_pairs(database) for i in pair}
    return set(model.reg_image_ids()) - matched


@dataclass(frozen=True)
class Placed:
    """The round's placements and the frame they are in (the base's scene frame): a sub-model of
    the result they mostly place is joined to the largest by them (core/join_groups.py)."""

    placements: Sequence[CameraEdit] = field(default_factory=tuple)
    frame: GroundFrame | None = None

    def join(self, models: list[pycolmap.Reconstruction], base: list[pycolmap.Reconstruction],
             touched: set[int], sparse_dir: Path) -> list[pycolmap.Reconstruction]:
        """The models joined (and written to sparse_dir in their place), or as they were."""
        if not self.placements or self.frame is None or not base:
            return models
        joined = join_groups.join_placed_after_map(models, base[0], touched,
                                                   list(self.placements), self.frame)
        if joined is not models:
            log.info("Joined by the placements after the map: %d model(s) -> %d, %d images in the "
                     "largest", len(models), len(joined), joined[0].num_reg_images())
            sfm.write_models(joined, sparse_dir)
        return joined


def warm_result_problem(base: pycolmap.Reconstruction, models: list[pycolmap.Reconstruction],
                        base_models: int, unmatched: int = 0) -> str | None:
    """Why a warm result is worse than its base (fewer images, a split, large error), or None;
    unmatched: the base's images with no pair left, which no map can register."""
    if models[0].num_reg_images() < base.num_reg_images() - unmatched:
        return f"{models[0].num_reg_images()} images registered, {base.num_reg_images()} before"
    if len(models) > base_models:
        return f"split into {len(models)} models, {base_models} before"
    before, after = base.compute_mean_reprojection_error(), models[0].compute_mean_reprojection_error()
    if after > max(before * MAX_ERROR_RATIO, before + MAX_ERROR_GAIN_PX):
        return f"mean reprojection error {after:.2f} px, {before:.2f} px before"
    return None


def holds_untouched_fixed(base: pycolmap.Reconstruction, touched: set[int]) -> bool:
    """Whether a warm start from base keeps the cameras the round did not touch fixed: when few
    are touched (FIX_EXISTING_SHARE), or when the untouched are many (FIX_EXISTING_ABOVE_UNTOUCHED)."""
    untouched = len(set(base.reg_image_ids()) - touched)
    return (len(touched) <= FIX_EXISTING_SHARE * max(1, base.num_reg_images())
            or untouched > FIX_EXISTING_ABOVE_UNTOUCHED)


def _map_warm(database: Path, image_dir: Path, sparse_dir: Path, base_models: list,
              touched: set[int], run: RunContext, keep_fixed: bool = False,
              placed: Placed = Placed()) -> tuple[list | None, str | None]:
    """(models, why they are worse than the base or None) of a map from base_models[0] without
    the touched images; (None, why) when it registered nothing."""
    base = base_models[0]
    fix = keep_fixed or holds_untouched_fixed(base, touched)
    unmatched = unmatched_images(database, base) - touched
    with tempfile.TemporaryDirectory() as tmp:
        without_images(base, touched | unmatched).write_binary(tmp)
        try:
            warm = sfm.map_database(database, image_dir, sparse_dir, run, input_model=Path(tmp),
                                    fix_existing=fix)
        except EmptyModel:
            return None, "the warm start registered nothing"
        except IndexError as exc:  # pycolmap on some models joined by a placement (issue 21)
            log.warning("The warm start failed (%s); mapping cold.", exc)
            return None, f"the warm start failed: {exc}"
    warm = placed.join(warm, base_models, touched, sparse_dir)
    return warm, warm_result_problem(base, warm, len(base_models), len(unmatched))


def map_warm_or_cold(database: Path, image_dir: Path, sparse_dir: Path, base_models: list,
                     touched: set[int], run: RunContext = RunContext(),
                     cold: bool = False, keep_fixed: bool = False,
                     placements: Sequence[CameraEdit] = (), frame: GroundFrame | None = None
                     ) -> tuple[list[pycolmap.Reconstruction], MapReport]:
    """Map into sparse_dir: warm from base_models[0] without the touched images (those a round
    edited) unless cold or there is no base; keep_fixed keeps the base's cameras fixed (a model
    joined by a placement: its parts share no matches a refinement could use). A sub-model the
    placements (in frame, the base's scene frame) mostly place is joined to the largest by them
    before the guard judges the result, warm or cold (Placed)."""
    placed = Placed(tuple(placements), frame)
    start = time.perf_counter()
    fallback, warm = None, None
    if not cold and base_models:
        warm, fallback = _map_warm(database, image_dir, sparse_dir, base_models, touched, run,
                                   keep_fixed, placed)
        if fallback is None:
            return warm, _report("warm", None, start, warm)
    try:
        models = placed.join(sfm.map_database(database, image_dir, sparse_dir, run), base_models,
                             touched, sparse_dir)
    except EmptyModel:
        if warm is None:
            raise
        models = []
    if warm is not None and (not models or _rank(warm) < _rank(models)):
        # The cold map did worse than the warm one it was meant to replace: keep the warm one.
        sfm.write_models(warm, sparse_dir)
        return warm, _report("warm", fallback, start, warm)
    return models, _report("cold", fallback, start, models)


def _rank(models: list[pycolmap.Reconstruction]) -> tuple[int, int]:
    """Better results sort first: more images in the largest model, then fewer models. A tie
    goes to the cold map: a fresh start cannot inherit the base's fold."""
    return (-models[0].num_reg_images(), len(models))


def _report(mode: str, fallback: str | None, start: float, models: list) -> MapReport:
    return MapReport(mode, fallback, round(time.perf_counter() - start, 2),
                     models[0].num_reg_images(), len(models))
