"""What the default rule tests the placements against, read once per preview (models and database
read-only): per model image its pose, keypoint rays and 3D points; per pair its inlier matches.
And the shape of a test's answer (Verdicts)."""

from __future__ import annotations

import copy
import functools
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pycolmap

from guided_sfm.core import colmap_db, model_files
from guided_sfm.core.colmap_model import ModelPose, model_poses
from guided_sfm.core.metrics import Similarity
from guided_sfm.core.types import PairKey

# A median angle or a 9x9 moment matrix settles long before a pair's hundreds of matches run out;
# thinning bounds a preview's cost by the number of pairs.
MAX_MATCHES_PER_PAIR = 96


@dataclass(frozen=True)
class Evidence:
    """Rows are images of the largest model; keypoint arrays are concatenated row after row."""

    rows: dict[int, int]  # image id -> row
    rotations: np.ndarray  # (I, 3, 3) cam_from_world
    translations: np.ndarray  # (I, 3) cam_from_world
    offsets: np.ndarray  # (I + 1,) first keypoint of each row
    rays: np.ndarray  # (K, 3) unit viewing rays in the camera frame (undistorted)
    points: np.ndarray  # (K, 3) the keypoint's 3D point (model coordinates), NaN where none
    matches: Mapping[PairKey, np.ndarray]  # (M, 2) inlier keypoint indices, pair-key order


@dataclass(frozen=True)
class FlatMatches:
    """The inlier matches of P tested pairs, concatenated pair after pair (at most
    MAX_MATCHES_PER_PAIR each, evenly spread over the pair's list)."""

    pair: np.ndarray  # (M,) index of the tested pair each match belongs to, ascending
    keypoints: np.ndarray  # (M, 2) global keypoint index (into rays/points) of each side
    rows: np.ndarray  # (P, 2) evidence row of each pair member, -1 when not in the model
    counts: np.ndarray  # (P,) matches kept per pair (0 when a member is not in the model)
    inliers: np.ndarray  # (P,) the pair's verified inliers, before thinning


class Verdicts(NamedTuple):
    """A test's answer per tested pair: removed, judged (False: no verdict here, another test
    decides), and the measure it judged by (NaN where it gave no verdict)."""

    removed: np.ndarray
    judged: np.ndarray
    measure: np.ndarray


def _thinned(block: np.ndarray) -> np.ndarray:
    if len(block) <= MAX_MATCHES_PER_PAIR:
        return block
    return block[np.linspace(0, len(block) - 1, MAX_MATCHES_PER_PAIR).astype(np.int64)]


def flat_matches(evidence: Evidence, tested: np.ndarray) -> FlatMatches:
    """Gather the tested pairs' matches as flat arrays the tests can vectorise over."""
    lookup = np.full(max(evidence.rows, default=0) + 2, -1, dtype=np.int64)
    lookup[list(evidence.rows)] = list(evidence.rows.values())
    rows = lookup[np.minimum(tested, len(lookup) - 1)].reshape(-1, 2)
    empty = np.zeros((0, 2), dtype=np.int64)
    full = [evidence.matches.get((int(a), int(b)), empty) if ra >= 0 and rb >= 0 else empty
            for (a, b), (ra, rb) in zip(tested.tolist(), rows.tolist(), strict=True)]
    blocks = [_thinned(block) for block in full]
    counts = np.array([len(block) for block in blocks], dtype=np.int64)
    local = np.concatenate([empty, *blocks])
    pair = np.repeat(np.arange(len(tested)), counts)
    keypoints = local + evidence.offsets[rows[pair]] if len(local) else local
    return FlatMatches(pair, keypoints, rows, counts,
                       np.array([len(block) for block in full], dtype=np.int64))


def _rays(camera: pycolmap.Camera, xy: np.ndarray) -> np.ndarray:
    if len(xy) == 0:
        return np.zeros((0, 3))
    rays = np.column_stack([camera.cam_from_img(xy), np.ones(len(xy))])
    return rays / np.linalg.norm(rays, axis=1, keepdims=True)


def pairs_touching(pairs: Iterable[PairKey], image_ids: Iterable[int]) -> list[PairKey]:
    """The pairs with at least one member among image_ids."""
    ids = set(image_ids)
    return [pair for pair in pairs if pair[0] in ids or pair[1] in ids]


class ModelParts(NamedTuple):
    """What every preview on a model reads whatever the edit: poses, cameras, points."""

    poses: dict[int, ModelPose]
    cameras: dict[int, pycolmap.Camera]  # by image id
    points: tuple[np.ndarray, np.ndarray]  # read_points' sorted ids and xyz


@functools.lru_cache(maxsize=4)
def _model_parts(model_dir: str, _stamp: tuple[int, ...]) -> ModelParts:
    model = pycolmap.Reconstruction(model_dir)
    poses = model_poses(model)
    # copies: a reference into the model would keep all of it (every point's track) in the cache
    by_id = {camera_id: copy.copy(camera) for camera_id, camera in model.cameras.items()}
    cameras = {i: by_id[model.image(i).camera_id] for i in poses}
    return ModelParts(poses, cameras, model_files.read_points(Path(model_dir)))


def model_parts(model_dir: Path) -> ModelParts:
    """The model's parts, kept for the last four models read (a split version's largest model and
    the sub-models its placements join, or two versions): a version's model never changes and
    its previews repeat as the user edits (at 1,000 cameras loading them is most of a preview).
    Keyed by the files' size and time as well, so a model written again is read again."""
    files = [Path(model_dir) / name for name in ("cameras.bin", "images.bin", "points3D.bin")]
    stamp = tuple(v for f in files for v in (f.stat().st_mtime_ns, f.stat().st_size))
    return _model_parts(str(Path(model_dir).resolve()), stamp)


def gather(database: Path, model_dir: Path, pairs: Iterable[PairKey],
           joined: Sequence[tuple[Path, Similarity]] = ()) -> Evidence:
    """Evidence for these pairs from the largest model at model_dir and the matching database:
    the model's parts (cached), and only the tested images' keypoints and the tested pairs' matches.

    joined: placed sub-models (folder, the similarity carrying it into the largest model's world,
    join_groups.placed_similarities), read for the images the largest does not hold, their poses
    and points carried as the prune's join carries them: a sub-model's own matches then judge
    its placed cameras, not the frustum test alone.
    """
    pairs = list(pairs)
    wanted = {i for pair in pairs for i in pair}
    carried: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = {}
    for directory, sim in [(model_dir, None), *joined]:
        parts = model_parts(directory)
        ids = sorted(i for i in parts.poses if i in wanted and i not in carried)
        observations = model_files.read_observations(directory, ids)
        point_ids, xyz = parts.points
        for image_id in ids:
            xy, observed = observations[image_id]
            pose = parts.poses[image_id]
            rotation, translation = pose.rotation, pose.translation
            points = model_files.points_of(observed, point_ids, xyz)
            if sim is not None:  # cam_from_largest = cam_from_own . own_from_largest
                rotation = sim.apply_rotation(rotation)
                translation = sim.scale * pose.translation - rotation @ sim.translation
                points = sim.apply(points)
            carried[image_id] = (rotation, translation, _rays(parts.cameras[image_id], xy), points)
    image_ids = sorted(carried)
    rotations, translations, rays, points = ([carried[i][k] for i in image_ids] for k in range(4))
    counts = [len(r) for r in rays]
    held = dict(zip(image_ids, counts, strict=True))
    return Evidence(
        rows={image_id: row for row, image_id in enumerate(image_ids)},
        rotations=np.array(rotations).reshape(-1, 3, 3),
        translations=np.array(translations).reshape(-1, 3),
        offsets=np.concatenate([[0], np.cumsum(counts)]).astype(np.int64),
        rays=np.concatenate([np.zeros((0, 3)), *rays]),
        points=np.concatenate([np.zeros((0, 3)), *points]),
        matches=_held_matches(colmap_db.inlier_matches_of(database, pairs), held,
                              colmap_db.keypoint_counts(database, image_ids)),
    )


def _held_matches(matches: Mapping[PairKey, np.ndarray], held: Mapping[int, int],
                  listed: Mapping[int, int]) -> dict[PairKey, np.ndarray]:
    """The matches the model's 2D points can stand for: a match names a keypoint by its index in
    the database's list, the rays and 3D points are the model's list. A model mapped from this
    database holds its list whole; one that holds another (fewer points: known poses only, another
    extraction) lends its image no match, and an index past the list (a foreign database) is left
    out: read as it is, it would be another keypoint's ray, or another image's."""
    out = {}
    for (a, b), rows in matches.items():
        if a in held and b in held and held[a] == listed.get(a) and held[b] == listed.get(b):
            out[(a, b)] = rows[(rows[:, 0] < held[a]) & (rows[:, 1] < held[b])]
    return out
