"""Ground truth of a rendered sample: camera poses, intrinsics, depth maps, and false-pair labels."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from guided_sfm.core import colmap_db
from guided_sfm.core.errors import InvalidInput, MissingWorkspace
from guided_sfm.core.geometry import rotation_from_qvec
from guided_sfm.core.types import PairKey

REPROJECTION_PX = 4.0  # a match is wrong when its lifted keypoint lands farther than this
FALSE_PAIR_SHARE = 0.5  # a pair is false when at least this share of its inliers is wrong


@dataclass(frozen=True)
class TruthCamera:
    """A true camera: cam_from_world rotation and translation, and its centre (world, metres)."""

    rotation: np.ndarray
    translation: np.ndarray
    center: np.ndarray


@dataclass(frozen=True)
class Truth:
    """A sample's truth.json, plus where its depth maps live (None when it has none)."""

    up: np.ndarray
    cameras: dict[str, TruthCamera]
    intrinsics: np.ndarray | None
    depth_dir: Path | None


def load_truth(path: Path) -> Truth:
    """Read truth.json ({"units", "up", "camera"?, "images": [{name, center, qvec, tvec}]})."""
    path = Path(path)
    if not path.is_file():
        raise MissingWorkspace(f"no ground truth file at {path}")
    try:
        data = json.loads(path.read_text())
        cameras = {
            item["name"]: TruthCamera(
                rotation_from_qvec(item["qvec"]),
                np.asarray(item["tvec"], dtype=float),
                np.asarray(item["center"], dtype=float),
            )
            for item in data["images"]
        }
    except (ValueError, KeyError, TypeError) as exc:
        raise InvalidInput(f"malformed ground truth {path.name}: {exc}") from exc
    depth_dir = path.parent / "depth"
    return Truth(
        up=np.asarray(data.get("up", [0, 0, 1]), dtype=float),
        cameras=cameras,
        intrinsics=_intrinsics(data.get("camera")),
        depth_dir=depth_dir if depth_dir.is_dir() else None,
    )


def _intrinsics(camera: dict | None) -> np.ndarray | None:
    if not camera:
        return None
    return np.array([[camera["fx"], 0, camera["cx"]], [0, camera["fy"], camera["cy"]], [0, 0, 1]])


def _depth(truth: Truth, name: str) -> np.ndarray:
    return np.load(truth.depth_dir / (Path(name).stem + ".npy"))


def wrong_match_share(truth: Truth, name1: str, name2: str, xy1: np.ndarray,
                      xy2: np.ndarray) -> float:
    """Share of matches (xy1[i] <-> xy2[i], COLMAP pixels) whose lifted point misses its match."""
    depth = _depth(truth, name1)
    cols = np.clip(xy1[:, 0].astype(int), 0, depth.shape[1] - 1)
    rows = np.clip(xy1[:, 1].astype(int), 0, depth.shape[0] - 1)
    z = depth[rows, cols].astype(float)
    k_inv = np.linalg.inv(truth.intrinsics)
    pixels = np.column_stack([xy1 - 0.5, np.ones(len(xy1))])  # COLMAP origin: pixel corner
    in_cam1 = (pixels @ k_inv.T) * z[:, None]
    cam1, cam2 = truth.cameras[name1], truth.cameras[name2]
    world = (in_cam1 - cam1.translation) @ cam1.rotation
    in_cam2 = world @ cam2.rotation.T + cam2.translation
    projected = in_cam2 @ truth.intrinsics.T
    with np.errstate(divide="ignore", invalid="ignore"):
        xy = projected[:, :2] / projected[:, 2:3] + 0.5
    error = np.linalg.norm(xy - xy2, axis=1)
    wrong = ~np.isfinite(error) | (error > REPROJECTION_PX) | (in_cam2[:, 2] <= 0) | (z <= 0)
    return float(wrong.mean()) if len(wrong) else 0.0


def false_pairs(database: Path, truth: Truth) -> set[PairKey]:
    """Verified pairs of a database that are false under the ground truth (design.md)."""
    if truth.depth_dir is None or truth.intrinsics is None:
        raise InvalidInput("the ground truth has no depth maps or intrinsics to label pairs")
    names = colmap_db.image_names(database)
    keypoints: dict[int, np.ndarray] = {}
    labelled = set()
    for pair, matches in colmap_db.all_inlier_matches(database).items():
        for image_id in pair:
            if image_id not in keypoints:
                keypoints[image_id] = colmap_db.keypoints(database, image_id)
        xy1 = keypoints[pair[0]][matches[:, 0]]
        xy2 = keypoints[pair[1]][matches[:, 1]]
        if wrong_match_share(truth, names[pair[0]], names[pair[1]], xy1, xy2) >= FALSE_PAIR_SHARE:
            labelled.add(pair)
    return labelled
