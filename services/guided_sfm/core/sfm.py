"""pycolmap steps: SIFT extraction, matching, mapping; with progress reports and cancellation."""

from __future__ import annotations

import logging
import shutil
import tempfile
from collections.abc import Sequence
from contextlib import contextmanager
from dataclasses import asdict, dataclass
from itertools import combinations
from pathlib import Path

import pycolmap
from PIL import Image

from guided_sfm.core import colmap_db
from guided_sfm.core.errors import Cancelled, EmptyModel, InvalidInput
from guided_sfm.core.types import Progress, no_progress

log = logging.getLogger(__name__)

MATCHERS = ("exhaustive", "sequential")
# SIFT (first octave, contrast threshold). "fast" starts at the image's own resolution instead of
# twice it and lowers the threshold: ~900 instead of ~2,300 features on the 640x480 samples and a
# first reconstruction ~8x faster than the default path, but weaker: the real Lund street walk
# registers 4 of 29 images and murals' correction may not finish (docs/engine.md). Opt-in.
FEATURES = {"standard": (-1, 0.02 / 3), "fast": (0, 0.003)}
MAPPERS = ("incremental", "global")
CAMERA_MODELS = ("SIMPLE_PINHOLE", "PINHOLE", "SIMPLE_RADIAL", "RADIAL", "OPENCV")
EXTRACT_CHUNK = 8  # images per extraction call: one progress report each
MATCH_CHUNKS = 20  # progress reports during matching
# A cold incremental map now and then settles on a dead-end initial pair (Lund, a forward walk:
# 2 of 29 images in 2 of about 10 runs on 2 threads); it starts again, with another seed,
# while its largest model holds less than this share of the images.
COLD_START_ATTEMPTS, COLD_START_SHARE = 3, 0.5


@dataclass(frozen=True)
class SfmOptions:
    """Every knob of a reconstruction; the defaults are the product's default path."""

    camera_model: str = "SIMPLE_RADIAL"
    matcher: str = "exhaustive"
    mapper: str = "incremental"
    # 4096 features keep exhaustive matching of ~50 indoor images near a minute on 2 cores
    # while leaving hundreds of verified inliers per neighbouring pair.
    max_num_features: int = 4096
    features: str = "standard"  # a key of FEATURES
    sequential_overlap: int = 10
    # COLMAP's default of 30 also rejects initial pairs that triangulate fewer points; forward
    # walks such as the Lund street then never start (2 of 29 images); 15 registers 28 of 29.
    min_registration_inliers: int = 15
    num_threads: int = 2
    seed: int = 0

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
        if self.num_threads < 1 or self.max_num_features < 64:
            raise InvalidInput("num_threads must be >= 1 and max_num_features >= 64")

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


def _token(cancel: CancelToken | None) -> pycolmap.CancellationToken | None:
    return None if cancel is None else cancel.colmap


def _check(cancel: CancelToken | None) -> None:
    if cancel is not None:
        cancel.check()


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


def _groups_by_size(image_dir: Path, names: Sequence[str]) -> list[list[str]]:
    """Names grouped by image size: one camera per size (portrait and landscape differ)."""
    groups: dict[tuple[int, int], list[str]] = {}
    for name in names:
        with Image.open(image_dir / name) as img:
            groups.setdefault(img.size, []).append(name)
    return list(groups.values())


def extract_features(
    image_dir: Path,
    database: Path,
    options: SfmOptions = SfmOptions(),
    progress: Progress = no_progress,
    cancel: CancelToken | None = None,
    image_names: Sequence[str] | None = None,
) -> None:
    """SIFT features of every image into the database (images already there are skipped)."""
    names = list(image_names) if image_names is not None else list_images(image_dir)
    extraction = pycolmap.FeatureExtractionOptions()
    extraction.num_threads = options.num_threads
    extraction.use_gpu = False
    extraction.sift.max_num_features = options.max_num_features
    extraction.sift.first_octave, extraction.sift.peak_threshold = FEATURES[options.features]
    done = 0
    for group in _groups_by_size(image_dir, names):
        camera_id = -1
        for start in range(0, len(group), EXTRACT_CHUNK):
            _check(cancel)
            chunk = group[start : start + EXTRACT_CHUNK]
            reader = pycolmap.ImageReaderOptions()
            reader.camera_model = options.camera_model
            reader.existing_camera_id = camera_id
            with _cancellable():
                pycolmap.extract_features(
                    database, image_dir, image_names=chunk,
                    camera_mode=pycolmap.CameraMode.SINGLE, reader_options=reader,
                    extraction_options=extraction, device=pycolmap.Device.cpu,
                    cancellation_token=_token(cancel),
                )
            if camera_id == -1:
                camera_id = _camera_of(database, chunk[0])
            done += len(chunk)
            progress("extract", done / len(names))
    _check(cancel)


def _camera_of(database: Path, name: str) -> int:
    with colmap_db.read_only(database) as conn:
        return conn.execute("SELECT camera_id FROM images WHERE name = ?", (name,)).fetchone()[0]


def _image_ids_in_order(database: Path) -> list[int]:
    names = colmap_db.image_names(database)
    return sorted(names, key=names.__getitem__)


def candidate_pairs(image_ids: Sequence[int], matcher: str, overlap: int = 10) -> list[tuple]:
    """Image pairs a matcher compares: all pairs, or a window along capture order."""
    if matcher == "exhaustive":
        return list(combinations(image_ids, 2))
    pairs = []
    for i, image_id in enumerate(image_ids):
        pairs += [(image_id, other) for other in image_ids[i + 1 : i + 1 + overlap]]
    return pairs


def match_features(
    database: Path,
    options: SfmOptions = SfmOptions(),
    progress: Progress = no_progress,
    cancel: CancelToken | None = None,
) -> None:
    """Match and geometrically verify the candidate pairs, in chunks so progress is real."""
    db_names = colmap_db.image_names(database)
    pairs = candidate_pairs(_image_ids_in_order(database), options.matcher,
                            options.sequential_overlap)
    matching = pycolmap.FeatureMatchingOptions()
    matching.num_threads = options.num_threads
    matching.use_gpu = False
    verification = pycolmap.TwoViewGeometryOptions()
    verification.ransac.random_seed = options.seed
    chunk = max(1, -(-len(pairs) // MATCH_CHUNKS))
    with tempfile.TemporaryDirectory() as tmp:
        pair_file = Path(tmp) / "pairs.txt"
        for start in range(0, len(pairs), chunk):
            _check(cancel)
            block = pairs[start : start + chunk]
            pair_file.write_text("".join(f"{db_names[a]} {db_names[b]}\n" for a, b in block))
            pairing = pycolmap.ImportedPairingOptions()
            pairing.match_list_path = pair_file
            with _cancellable():
                pycolmap.match_image_pairs(
                    database, matching_options=matching, pairing_options=pairing,
                    verification_options=verification, device=pycolmap.Device.cpu,
                    cancellation_token=_token(cancel),
                )
            progress("match", min(1.0, (start + len(block)) / len(pairs)))
    _check(cancel)


def _incremental_options(options: SfmOptions, image_dir: Path) -> pycolmap.IncrementalPipelineOptions:
    mapping = pycolmap.IncrementalPipelineOptions()
    mapping.num_threads = options.num_threads
    mapping.random_seed = options.seed
    mapping.image_path = image_dir
    mapping.mapper.abs_pose_min_num_inliers = options.min_registration_inliers
    return mapping


def _largest(models: dict) -> int:
    return max((model.num_reg_images() for model in models.values()), default=0)


def map_database(
    database: Path,
    image_dir: Path,
    sparse_dir: Path,
    options: SfmOptions = SfmOptions(),
    progress: Progress = no_progress,
    cancel: CancelToken | None = None,
    input_model: Path | None = None,
    fix_existing: bool = False,
) -> list[pycolmap.Reconstruction]:
    """Map the database into sparse_dir/0, /1, ... (largest model first); returns the models."""
    _check(cancel)
    num_images = max(1, len(colmap_db.image_names(database)))
    with tempfile.TemporaryDirectory() as tmp:
        if options.mapper == "global":
            mapping = pycolmap.GlobalPipelineOptions()
            mapping.num_threads = options.num_threads
            mapping.random_seed = options.seed
            progress("map", 0.0)
            models = pycolmap.global_mapping(database, image_dir, tmp, mapping)
        else:
            registered = [0]

            def next_image() -> None:
                registered[0] += 1
                progress("map", min(0.99, registered[0] / num_images))

            models = {}
            for attempt in range(1 if input_model else COLD_START_ATTEMPTS):
                mapping = _incremental_options(options, image_dir)
                mapping.random_seed = options.seed + attempt
                mapping.fix_existing_frames = fix_existing
                with _cancellable():
                    found = pycolmap.incremental_mapping(
                        database, image_dir, tmp, mapping,
                        input_path=input_model or "", next_image_callback=next_image,
                        cancellation_token=_token(cancel),
                    )
                _check(cancel)
                if _largest(found) > _largest(models):
                    models = found
                if _largest(models) >= COLD_START_SHARE * num_images:
                    break
                log.warning("A cold start registered %d of %d images; starting again.",
                            _largest(models), num_images)
    _check(cancel)
    ordered = sorted(models.values(), key=lambda rec: -rec.num_reg_images())
    if not ordered:
        raise EmptyModel("mapping registered no images: too few verified matches")
    write_models(ordered, sparse_dir)
    progress("map", 1.0)
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
