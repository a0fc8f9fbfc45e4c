"""numpy readers of COLMAP's binary model files, for the fields pycolmap hands out one object at a time.

pycolmap exposes a keypoint's 3D point only through per-point Python objects (~20 us each), too
slow for a live preview over thousands of keypoints per image; these read the arrays directly.
"""

from __future__ import annotations

import struct
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from guided_sfm.core.errors import MissingWorkspace

POINT2D = np.dtype([("xy", "<f8", 2), ("point3D_id", "<i8")])
IMAGE_HEADER = struct.Struct("<I7dI")  # image_id, qvec (w, x, y, z), tvec, camera_id
POINT3D_HEADER = 51  # id u64, xyz 3 f64, rgb 3 u8, error f64, track length u64
NO_POINT = -1  # COLMAP's invalid point3D id (2^64 - 1) read as a signed integer


def _read(path: Path) -> bytes:
    if not Path(path).is_file():
        raise MissingWorkspace(f"no COLMAP model file at {path}")
    return Path(path).read_bytes()


def read_observations(model_dir: Path, image_ids: Iterable[int] | None = None
                      ) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """image id -> ((N, 2) keypoints in pixels, (N,) point3D id or -1) from images.bin."""
    data = _read(Path(model_dir) / "images.bin")
    wanted = None if image_ids is None else set(image_ids)
    (count,), offset = struct.unpack_from("<Q", data, 0), 8
    out = {}
    for _ in range(count):
        image_id = IMAGE_HEADER.unpack_from(data, offset)[0]
        offset = data.index(b"\0", offset + IMAGE_HEADER.size) + 1  # past the file name
        (num_points,), offset = struct.unpack_from("<Q", data, offset), offset + 8
        if wanted is None or image_id in wanted:
            rows = np.frombuffer(data, POINT2D, num_points, offset)
            out[image_id] = (rows["xy"].astype(float), rows["point3D_id"].copy())
        offset += num_points * POINT2D.itemsize
    return out


def read_points(model_dir: Path) -> tuple[np.ndarray, np.ndarray]:
    """(sorted point3D ids, (N, 3) xyz in model coordinates) from points3D.bin."""
    data = _read(Path(model_dir) / "points3D.bin")
    (count,) = struct.unpack_from("<Q", data, 0)
    starts = np.empty(count, dtype=np.int64)
    offset = 8
    for i in range(count):  # records vary in length with their tracks, so walk them once
        starts[i] = offset
        offset += POINT3D_HEADER + 8 * int.from_bytes(data[offset + 43:offset + 51], "little")
    raw = np.frombuffer(data, np.uint8)
    ids = raw[starts[:, None] + np.arange(8)].copy().view("<i8").ravel()
    xyz = raw[starts[:, None] + 8 + np.arange(24)].copy().view("<f8").reshape(-1, 3)
    order = np.argsort(ids)
    return ids[order], xyz[order]


def points_of(point_ids: np.ndarray, ids: np.ndarray, xyz: np.ndarray) -> np.ndarray:
    """(N, 3) xyz of each point id (read_points' sorted ids and xyz); NaN where there is none."""
    out = np.full((len(point_ids), 3), np.nan)
    if len(ids) == 0:
        return out
    rows = np.minimum(np.searchsorted(ids, point_ids), len(ids) - 1)
    found = ids[rows] == point_ids  # NO_POINT matches no stored point
    out[found] = xyz[rows[found]]
    return out
