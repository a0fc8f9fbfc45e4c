"""pycolmap steps: SIFT extraction, matching, mapping; each takes a RunContext (options, progress
reports, cancellation) from its caller."""

from __future__ import annotations

import logging
import shutil
import tempfile
from collections.abc import Collection, Sequence
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field, replace
from itertools import combinations
from pathlib import Path

import pycolmap
from PIL import Image

from guided_sfm.core import colmap_db, join_groups, retrieval
from guided_sfm.core.errors import Cancelled, EmptyModel, InvalidInput
from guided_sfm.core.types import Progress, no_progress

log = logging.getLogger(__name__)

MATCHERS = ("auto", "exhaustive", "sequential", "retrieval")
# `auto` matches exhaustively up to this many images and by retrieval above it. Exhaustive pairs
# grow as n^2/2; retrieval's as about 15 n (20 retrieved and 10 along capture order per image,
# many shared), plus training and querying the tree (~12 s at 115 images). Measured side by side
# on the rendered hall (benchmarks/bench_scale.py, docs/engine.md "Matching at scale"), matching
# took 8.8 s exhaustive against 6.2 s retrieval at 55 images and 36 s against 27 s at 115, with
# the same registration and wrong cameras. Below 100 retrieval saves seconds, not minutes, so
# small captures keep every pair: all those the product was tuned on (murals 57, Lund 29).
AUTO_EXHAUSTIVE_MAX_IMAGES = 100
# SIFT (first octave, contrast threshold). "standard" starts at the image's own resolution, not
# twice it, and lowers the threshold to keep the count: COLMAP drops the finest scales first when
# it caps, so the doubled octave was mostly computed and thrown away (extraction 3x faster on
# murals, same registration on murals and Lund, docs/engine.md). "colmap" is COLMAP's own.
FEATURES = {"standard": (0, 0.003), "colmap": (-1, 0.02 / 3)}
MAPPERS = ("incremental", "global", "hierarchical")
CAMERA_MODELS = ("SIMPLE_PINHOLE", "PINHOLE", "SIMPLE_RADIAL", "RADIAL", "OPENCV")
# About this many extraction and matching calls, one progress report each. Every call sets up
# COLMAP's extractor or matcher cache again, so fewer calls are faster (measured on murals).
EXTRACT_CHUNKS, MIN_EXTRACT_CHUNK = 10, 8
MATCH_CHUNKS = 10
# A cold incremental map now and then settles on a dead-end initial pair (Lund, a forward walk:
# 2 of 29 images in 2 of about 10 runs on 2 threads); it starts again, with another seed,
# while its largest model holds less than this share of the images. Above
# LARGE_MAP_ABOVE_IMAGES only while its models together hold less than the share as well
# (cold_start_worth_retrying): hall-1000 split into two legs of ~496 images at both turns, and
# two more starts of 13 and 23 min gave the same 496 (docs/engine.md "Registration at scale").
COLD_START_ATTEMPTS, COLD_START_SHARE = 3, 0.5
# Above this many images a cold incremental map is "large": its global BAs are sparser
# (LARGE_GLOBAL_BA_RATIO) and its sub-models that share registered images with the largest are
# joined into it (join_groups.join_overlapping): hall-300 split at its far turn
# into 164 + 150 cameras sharing 20, joined 294 of 295 in one model (docs/engine.md "Matching at
# scale"). Below it COLMAP's models are kept as they come: the small captures' figures stand.
LARGE_MAP_ABOVE_IMAGES = AUTO_EXHAUSTIVE_MAX_IMAGES
# A large cold incremental map runs its global BA each time the
# model grows by half, not COLMAP's 10% (the final global BA still runs): hall-300 mapped in
# 451 s against 684 s side by side, 294 registered both, 143 wrong against 136 (one run each,
# docs/engine.md "Matching at scale"). Small captures keep COLMAP's 10%.
LARGE_GLOBAL_BA_RATIO = 1.5
WARM_GLOBAL_BA_RATIO = 2.0  # growth between global BAs when mapping from a previous model
# See SfmOptions.placement_prior and docs/pruning-rule.md ("The placement as a pose prior").
PLACEMENT_PRIOR_DEFAULT = False
# SIFT features kept per image, by area. Exhaustive matching grows with the square of the
# count; a density (not COLMAP's flat 8,192) keeps small images cheap and large ones matched:
# 1,024 for the 640x480 samples, 2,621 for the 1024x768 Lund photographs (docs/engine.md).
FEATURES_PER_MEGAPIXEL, FEATURE_BOUNDS = 3333, (1024, 8192)
# SIFT runs on photos scaled down to this longest side (COLMAP's "medium" quality; its own default
# is 3200). On the rendered hall at 4000x3000 (20 views) it registered all 20 with none wrong,
# as 3200 did (1 wrong), for 3.4x less CPU in extraction, 2.6x in matching and 3.7x in mapping;
# images at or below it (the 640x480 samples, Lund's 1024x768) keep exactly the same features
# (docs/engine.md "Real photo resolution").
DEFAULT_MAX_IMAGE_SIZE = 1600


def features_for_size(width: int, height: int) -> int:
    """The default SIFT feature budget of a width x height image."""
    budget = round(FEATURES_PER_MEGAPIXEL * width * height / 1e6)
    return int(min(max(budget, FEATURE_BOUNDS[0]), FEATURE_BOUNDS[1]))


@dataclass(frozen=True)
class SfmOptions:
    """Every knob of a reconstruction; the defaults are the product's default path."""

    camera_model: str = "SIMPLE_RADIAL"
    matcher: str = "auto"  # a key of MATCHERS; matcher_for() says what auto means for n images
    mapper: str = "incremental"
    # None: a budget that follows the image's area (features_for_size); a number overrides it.
    max_num_features: int | None = None
    features: str = "standard"  # a key of FEATURES
    # Longest image side SIFT runs at (the image is scaled down, its keypoints scaled back to the
    # file's pixels); None: COLMAP's own, 3200 for SIFT. See DEFAULT_MAX_IMAGE_SIZE.
    max_image_size: int | None = DEFAULT_MAX_IMAGE_SIZE
    sequential_overlap: int = 10
    # COLMAP's default of 30 also rejects initial pairs that triangulate fewer points; forward
    # walks such as the Lund street then never start (2 of 29 images); 15 registers 28 of 29.
    min_registration_inliers: int = 15
    num_threads: int = 2
    seed: int = 0
    # Hold an incremental re-map to the position priors a correction round wrote into the
    # database (core/pose_prior.py: the user's placement, the unmoved cameras where they were).
    placement_prior: bool = PLACEMENT_PRIOR_DEFAULT

    def __post_init__(self) -> None:
        if self.matcher not in MATCHERS:
            raise InvalidInput(f"unknown matcher {self.matcher!r}; choose one of {MATCHERS}")
        if self.features not in FEATURES:
            raise InvalidInput(f"unknown features {self.features!r}; choose one of {tuple(FEATURES)}")
        if self.mapper not in MAPPERS:
            raise InvalidInput(f"unknown mapper {self.mapper!r}; choose one of {MAPPERS}")
        if self.camera_model not in CAMERA_MODELS:
            raise InvalidInput(
                f"unknown camera model {self.camera_model!r}; choose one of {CAMERA_MODELS}"
            )
        if self.num_threads < 1 or (self.max_num_features is not None
                                    and self.max_num_features < 64):
            raise InvalidInput("num_threads must be >= 1 and max_num_features >= 64")
        if self.max_image_size is not None and self.max_image_size < 64:
            raise InvalidInput("max_image_size must be >= 64")

    def to_dict(self) -> dict[str, object]:
        return asdict(self)


class CancelToken:
    """A cancellation flag shared with pycolmap's own token, checked between steps too."""

    def __init__(self) -> None:
        self.colmap = pycolmap.CancellationToken()

    def cancel(self) -> None:
        self.colmap.cancel()

    @property
    def cancelled(self) -> bool:
        return bool(self.colmap.is_cancelled)

    def check(self) -> None:
        if self.cancelled:
            raise Cancelled("the job was cancelled")


@dataclass(frozen=True)
class RunContext:
    """What a long step takes from its caller: the SfM options, where to report progress, and the
    cancellation token (None: the run cannot be cancelled)."""

    options: SfmOptions = field(default_factory=SfmOptions)
    progress: Progress = no_progress
    cancel: CancelToken | None = None

    def check(self) -> None:
        """Raise Cancelled once the run was cancelled."""
        if self.cancel is not None:
            self.cancel.check()

    @property
    def token(self) -> pycolmap.CancellationToken | None:
        """The token pycolmap's own loops watch."""
        return None if self.cancel is None else self.cancel.colmap

    def reporting_to(self, progress: Progress) -> RunContext:
        """The same run with its progress reports sent to another callback."""
        return replace(self, progress=progress)


@contextmanager
def _cancellable():
    """pycolmap reports a cancelled token as InterruptedError; callers see Cancelled."""
    try:
        yield
    except InterruptedError as exc:
        raise Cancelled("the job was cancelled") from exc


def list_images(image_dir: Path) -> list[str]:
    """Image file names of a directory in capture order (file-name order)."""
    suffixes = {".jpg", ".jpeg", ".png"}
    names = sorted(p.name for p in Path(image_dir).iterdir() if p.suffix.lower() in suffixes)
    if not names:
        raise InvalidInput(f"no JPEG or PNG images in {image_dir}")
    return names


def _groups_by_size(image_dir: Path, names: Sequence[str]) -> dict[tuple[int, int], list[str]]:
    """Names grouped by image size: each size gets its own feature budget (and, once joined, camera)."""
    groups: dict[tuple[int, int], list[str]] = {}
    for name in names:
        with Image.open(image_dir / name) as img:
            groups.setdefault(img.size, []).append(name)
    return groups


def effective_max_image_size(options: SfmOptions) -> int:
    """The longest image side SIFT runs at with these options (COLMAP's own where they set none)."""
    extraction = pycolmap.FeatureExtractionOptions()
    if options.max_image_size is not None:
        extraction.max_image_size = options.max_image_size
    return extraction.eff_max_image_size()


def extract_features(image_dir: Path, database: Path, run: RunContext = RunContext(),
                     image_names: Sequence[str] | None = None) -> None:
    """SIFT features of every image into the database (images already there are skipped).

    Every image gets its own camera here; match_features joins them per kind of image once the
    pairs are verified (colmap_db.share_cameras says why).
    """
    names = list(image_names) if image_names is not None else list_images(image_dir)
    options = run.options
    extraction = pycolmap.FeatureExtractionOptions()
    extraction.num_threads = options.num_threads
    extraction.use_gpu = False
    if options.max_image_size is not None:
        extraction.max_image_size = options.max_image_size
    extraction.sift.first_octave, extraction.sift.peak_threshold = FEATURES[options.features]
    reader = pycolmap.ImageReaderOptions()
    reader.camera_model = options.camera_model
    step = max(MIN_EXTRACT_CHUNK, -(-len(names) // EXTRACT_CHUNKS))
    done = 0
    run.progress("extract", 0.0)  # the stage starts now, not after its first chunk (stage_clock)
    for size, group in _groups_by_size(image_dir, names).items():
        extraction.sift.max_num_features = options.max_num_features or features_for_size(*size)
        for start in range(0, len(group), step):
            run.check()
            chunk = group[start : start + step]
            with _cancellable():
                pycolmap.extract_features(
                    database, image_dir, image_names=chunk,
                    camera_mode=pycolmap.CameraMode.PER_IMAGE, reader_options=reader,
                    extraction_options=extraction, device=pycolmap.Device.cpu,
                    cancellation_token=run.token,
                )
            done += len(chunk)
            run.progress("extract", done / len(names))
    run.check()


def _image_ids_in_order(database: Path) -> list[int]:
    names = colmap_db.image_names(database)
    return sorted(names, key=names.__getitem__)


def matcher_for(matcher: str, num_images: int) -> str:
    """The matcher a run uses: `auto` resolved by the number of images, others as chosen."""
    if matcher != "auto":
        return matcher
    return "exhaustive" if num_images <= AUTO_EXHAUSTIVE_MAX_IMAGES else "retrieval"


def candidate_pairs(image_ids: Sequence[int], matcher: str, overlap: int = 10) -> list[tuple]:
    """Image pairs a matcher compares: all pairs, or a window along capture order (`auto` below
    its threshold is exhaustive; retrieval needs the database, see retrieval_candidates)."""
    matcher = matcher_for(matcher, len(image_ids))
    if matcher == "exhaustive":
        return list(combinations(image_ids, 2))
    if matcher == "retrieval":
        raise InvalidInput("retrieval pairs come from the database's vocabulary tree")
    pairs = []
    for i, image_id in enumerate(image_ids):
        pairs += [(image_id, other) for other in image_ids[i + 1 : i + 1 + overlap]]
    return pairs


def retrieval_candidates(database: Path, tree: Path, run: RunContext) -> list[tuple]:
    """Retrieval's pairs: each image with its nearest images by the vocabulary tree at `tree`
    (built from the database's own descriptors when the file is missing, and kept there for
    later runs), plus capture-order neighbours and loop closure."""
    image_ids, options = _image_ids_in_order(database), run.options
    if not tree.is_file():
        retrieval.build_tree(database, tree, options.num_threads)
    run.check()
    retrieved = retrieval.retrieved_pairs(database, tree, num_threads=options.num_threads)
    return retrieval.combine(image_ids, retrieved,
                             retrieval.order_pairs(image_ids, options.sequential_overlap))


def match_features(database: Path, run: RunContext = RunContext(),
                   tree: Path | None = None) -> str:
    """Match and geometrically verify the candidate pairs, with progress; then join the
    per-image cameras so the mapper refines one camera per kind of image. Returns the matcher
    used (what `auto` chose); retrieval keeps its tree at `tree` (default: beside the database)."""
    db_names, options = colmap_db.image_names(database), run.options
    run.progress("match", 0.0)  # before the first block: it is matching's time, not extraction's
    matcher = matcher_for(options.matcher, len(db_names))
    if matcher == "retrieval":
        pairs = retrieval_candidates(database, tree or database.parent / retrieval.TREE_FILE, run)
    else:
        pairs = candidate_pairs(_image_ids_in_order(database), matcher, options.sequential_overlap)
    log.info("Matching %d pairs of %d images (%s).", len(pairs), len(db_names), matcher)
    _match_pairs(database, db_names, pairs, run)
    run.check()
    colmap_db.share_cameras(database)
    return matcher


def _match_pairs(database: Path, db_names: dict[int, str], pairs: Sequence[tuple[int, int]],
                 run: RunContext) -> None:
    """Match and verify the pairs in blocks of images, one progress report per block."""
    matching = pycolmap.FeatureMatchingOptions()
    matching.num_threads = run.options.num_threads
    matching.use_gpu = False
    verification = pycolmap.TwoViewGeometryOptions()
    verification.ransac.random_seed = run.options.seed
    with tempfile.TemporaryDirectory() as tmp:
        pair_file = Path(tmp) / "pairs.txt"
        done = 0
        for block in _blocks_of_images(pairs):
            run.check()
            pair_file.write_text("".join(f"{db_names[a]} {db_names[b]}\n" for a, b in block))
            pairing = pycolmap.ImportedPairingOptions()
            pairing.match_list_path = pair_file
            with _cancellable():
                pycolmap.match_image_pairs(
                    database, matching_options=matching, pairing_options=pairing,
                    verification_options=verification, device=pycolmap.Device.cpu,
                    cancellation_token=run.token,
                )
            done += len(block)
            run.progress("match", done / len(pairs))


def _blocks_of_images(pairs: Sequence[tuple[int, int]]) -> list[list[tuple[int, int]]]:
    """The pairs in about MATCH_CHUNKS calls, each between two small blocks of images.

    Every call rebuilds COLMAP's per-image matcher cache, so a call should touch few images:
    20 slices of the pair list cost murals 45% more than one call, since each touched nearly
    every image; blocks of images keep that overhead small and progress still real.
    """
    images = sorted({i for pair in pairs for i in pair})
    per_side = max(1, round((2 * MATCH_CHUNKS) ** 0.5))  # k blocks give ~k^2/2 block pairs
    size = max(1, -(-len(images) // per_side))
    block_of = {image: index // size for index, image in enumerate(images)}
    groups: dict[tuple[int, int], list[tuple[int, int]]] = {}
    for a, b in pairs:
        groups.setdefault(tuple(sorted((block_of[a], block_of[b]))), []).append((a, b))
    return [groups[key] for key in sorted(groups)]


def _incremental_options(options: SfmOptions, image_dir: Path, attempt: int, fix_existing: bool,
                         warm: bool, priors: bool = False,
                         large: bool = False) -> pycolmap.IncrementalPipelineOptions:
    mapping = pycolmap.IncrementalPipelineOptions()
    # COLMAP's global bundle adjustment then aligns the map to the priors (a robust similarity)
    # and adds each registered camera's position, weighted by its covariance; with none in the
    # database the mapper would map nothing, hence only where some were written.
    mapping.use_prior_position = priors
    mapping.num_threads = options.num_threads
    mapping.random_seed = options.seed + attempt
    mapping.image_path = image_dir
    mapping.mapper.abs_pose_min_num_inliers = options.min_registration_inliers
    mapping.fix_existing_frames = fix_existing
    if warm:
        # The start is already a large model: a global BA each time it grows by 10% (COLMAP's
        # default) refines it again and again; the final global BA still runs. 2x re-mapped
        # murals 2.2x faster than cold (1.7x at 10%).
        mapping.ba_global_frames_ratio = WARM_GLOBAL_BA_RATIO
        mapping.ba_global_points_ratio = WARM_GLOBAL_BA_RATIO
    elif large:
        mapping.ba_global_frames_ratio = LARGE_GLOBAL_BA_RATIO
        mapping.ba_global_points_ratio = LARGE_GLOBAL_BA_RATIO
    return mapping


def _largest(models: dict) -> int:
    return max((model.num_reg_images() for model in models.values()), default=0)


def cold_start_worth_retrying(registered: Sequence[Collection[int]], num_images: int) -> bool:
    """Whether a cold map whose models registered these image ids may do better from another seed.

    Another seed helps a map that ran into a dead end: few images in any model. It cannot help a
    capture whose match graph is itself cut (a hall's legs joined by a handful of pairs at each
    turn): its models together hold most of the images, and each start finds the same pieces.
    Small captures keep the first rule alone (their figures stand)."""
    threshold = COLD_START_SHARE * num_images
    if max(map(len, registered), default=0) >= threshold:
        return False
    if num_images <= LARGE_MAP_ABOVE_IMAGES:
        return True
    return len(set().union(*registered)) < threshold


def _global_map(database: Path, image_dir: Path, out: str, run: RunContext) -> dict:
    mapping = pycolmap.GlobalPipelineOptions()
    mapping.num_threads = run.options.num_threads
    mapping.random_seed = run.options.seed
    run.progress("map", 0.0)
    return pycolmap.global_mapping(database, image_dir, out, mapping)


def _hierarchical_map(database: Path, image_dir: Path, out: str, run: RunContext) -> dict:
    """COLMAP's hierarchical mapping: the match graph cut into overlapping clusters, each mapped
    incrementally (with this product's registration threshold), then merged."""
    mapping = pycolmap.HierarchicalPipelineOptions()
    mapping.num_threads = run.options.num_threads
    mapping.image_path = image_dir
    incremental = _incremental_options(run.options, image_dir, 0, False, warm=False)
    mapping.incremental_options = incremental
    run.progress("map", 0.0)
    return pycolmap.hierarchical_mapping(database, image_dir, out, mapping)


def _incremental_map(database: Path, image_dir: Path, out: str, run: RunContext,
                     input_model: Path | None, fix_existing: bool, num_images: int) -> dict:
    """Incremental mapping, from input_model if given; a cold start that registers too little
    starts again with another seed (COLD_START_ATTEMPTS)."""
    registered = [0]

    def next_image() -> None:
        registered[0] += 1
        run.progress("map", min(0.99, registered[0] / num_images))

    models: dict = {}
    priors = run.options.placement_prior and colmap_db.count_pose_priors(database) >= 3
    for attempt in range(1 if input_model else COLD_START_ATTEMPTS):
        mapping = _incremental_options(run.options, image_dir, attempt, fix_existing,
                                       warm=input_model is not None, priors=priors,
                                       large=num_images > LARGE_MAP_ABOVE_IMAGES)
        with _cancellable():
            found = pycolmap.incremental_mapping(
                database, image_dir, out, mapping, input_path=input_model or "",
                next_image_callback=next_image, cancellation_token=run.token)
        run.check()
        if _largest(found) > _largest(models):
            models = found
        if not cold_start_worth_retrying(
                [model.reg_image_ids() for model in models.values()], num_images):
            break
        log.warning("A cold start registered %d of %d images; starting again.",
                    _largest(models), num_images)
    return models


def map_database(database: Path, image_dir: Path, sparse_dir: Path, run: RunContext = RunContext(),
                 input_model: Path | None = None,
                 fix_existing: bool = False) -> list[pycolmap.Reconstruction]:
    """Map the database into sparse_dir/0, /1, ... (largest model first); returns the models."""
    run.check()
    num_images = max(1, len(colmap_db.image_names(database)))
    with tempfile.TemporaryDirectory() as tmp:
        if run.options.mapper == "global":
            models = _global_map(database, image_dir, tmp, run)
        elif run.options.mapper == "hierarchical":
            models = _hierarchical_map(database, image_dir, tmp, run)
        else:
            models = _incremental_map(database, image_dir, tmp, run, input_model, fix_existing,
                                      num_images)
    run.check()
    ordered = sorted(models.values(), key=lambda rec: -rec.num_reg_images())
    if (run.options.mapper == "incremental" and input_model is None
            and num_images > LARGE_MAP_ABOVE_IMAGES and len(ordered) > 1):
        count = len(ordered)
        ordered = join_groups.join_overlapping(ordered)
        log.info("Joined %d of %d sub-models into the largest by their shared images.",
                 count - len(ordered), count - 1)
    if not ordered:
        raise EmptyModel("mapping registered no images: too few verified matches")
    write_models(ordered, sparse_dir)
    run.progress("map", 1.0)
    log.info("Mapped %d model(s); largest has %d images.", len(ordered),
             ordered[0].num_reg_images())
    return ordered


def write_models(models: Sequence[pycolmap.Reconstruction], sparse_dir: Path) -> None:
    """Replace sparse_dir with the models as 0, 1, ... (binary COLMAP)."""
    if sparse_dir.exists():
        shutil.rmtree(sparse_dir)
    for index, model in enumerate(models):
        out = sparse_dir / str(index)
        out.mkdir(parents=True)
        model.write_binary(out)


def set_colmap_verbosity(verbose: bool) -> None:
    """COLMAP logs every step at INFO; keep only errors unless asked, on stderr, not in files."""
    pycolmap.logging.logtostderr = True
    pycolmap.logging.minloglevel = 0 if verbose else 2
