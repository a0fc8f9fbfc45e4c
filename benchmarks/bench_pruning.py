"""Time Algorithm 1: vectorised prune_pairs against per-pair shapely loops.

Synthetic scenes: cameras at random 2D poses, each paired with its 30 nearest cameras, every
camera moved (jittered). Run: .venv/bin/python benchmarks/bench_pruning.py [--runs N]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
import shapely

from guided_sfm.core.rule.driver import prune_pairs
from guided_sfm.core.rule.frustum import frustum_polygons, placed_frusta
from guided_sfm.core.types import CameraEdit, EditSet, GroundFrame, SceneCamera, TopDownScene

NEIGHBOURS = 30
FOV_DEG, RANGE = 60.0, 8.0
FRAME = GroundFrame(np.zeros(3), np.array([1.0, 0, 0]), np.array([0, 1.0, 0]),
                    np.array([0, 0, 1.0]))


def nearest_pairs(xy: np.ndarray, k: int, chunk: int = 1000) -> dict[tuple[int, int], int]:
    """Pairs (1-based ids) of every camera with its k nearest cameras."""
    pairs = {}
    for start in range(0, len(xy), chunk):
        block = xy[start:start + chunk]
        dist = np.linalg.norm(block[:, None] - xy[None], axis=2)
        dist[np.arange(len(block)), np.arange(start, start + len(block))] = np.inf
        near = np.argpartition(dist, k, axis=1)[:, :k]
        for row, cols in enumerate(near):
            for col in cols:
                a, b = start + row + 1, int(col) + 1
                pairs[(min(a, b), max(a, b))] = 100
    return pairs


def synthetic(count: int, seed: int = 0) -> tuple[TopDownScene, EditSet, dict]:
    """Scene of `count` cameras on a square of constant density, every camera moved."""
    rng = np.random.default_rng(seed)
    side = 3.0 * np.sqrt(count)
    xy = rng.uniform(0, side, size=(count, 2))
    yaw = rng.uniform(-180, 180, size=count)
    cameras = [SceneCamera(i + 1, f"{i:05d}.png", i, True, 0, float(x), float(y), float(w),
                           FOV_DEG, RANGE, (float(x), float(y), 0.0), (1.0, 0.0, 0.0, 0.0))
               for i, ((x, y), w) in enumerate(zip(xy, yaw, strict=True))]
    moved_xy = xy + rng.normal(scale=4.0, size=xy.shape)
    moved_yaw = yaw + rng.normal(scale=60.0, size=count)
    edits = EditSet([CameraEdit(i + 1, float(x), float(y), float(w))
                     for i, ((x, y), w) in enumerate(zip(moved_xy, moved_yaw, strict=True))],
                    rule="paper")
    return TopDownScene(FRAME, cameras, np.zeros((0, 2))), edits, nearest_pairs(xy, NEIGHBOURS)


def prebuilt_loop(scene: TopDownScene, edits: EditSet, pairs) -> list[tuple[int, int]]:
    """Polygons built once per camera, then one .intersects call per pair."""
    poses = placed_frusta(scene, {e.image_id: e for e in edits.cameras})
    ids = list(poses)
    values = np.array([poses[i] for i in ids], dtype=float)
    polygons = dict(zip(ids, frustum_polygons(*values.T), strict=True))
    return sorted(p for p in pairs if not polygons[p[0]].intersects(polygons[p[1]]))


def naive_loop(scene: TopDownScene, edits: EditSet, pairs) -> list[tuple[int, int]]:
    """Both triangles built from the poses for every pair, then .intersects."""
    poses = placed_frusta(scene, {e.image_id: e for e in edits.cameras})
    deleted = []
    for a, b in pairs:
        triangles = [shapely.Polygon(_triangle(*poses[i])) for i in (a, b)]
        if not triangles[0].intersects(triangles[1]):
            deleted.append((a, b))
    return sorted(deleted)


def _triangle(x, y, yaw_deg, fov_deg, range_):
    half, yaw = np.radians(fov_deg) / 2, np.radians(yaw_deg)
    side = range_ / np.cos(half)
    return [(x, y), (x + side * np.cos(yaw - half), y + side * np.sin(yaw - half)),
            (x + side * np.cos(yaw + half), y + side * np.sin(yaw + half))]


def median_time(function, runs: int, *args):
    times, result = [], None
    for _ in range(runs):
        start = time.perf_counter()
        result = function(*args)
        times.append(time.perf_counter() - start)
    return statistics.median(times), result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5, help="runs per timing (median reported)")
    args = parser.parse_args()
    print(f"{'cameras':>8} {'pairs':>8} {'deleted':>8} {'vectorised s':>13} "
          f"{'prebuilt s':>11} {'naive s':>9} {'naive/vec':>10} {'same':>5}")
    for count in (1_000, 10_000):
        scene, edits, pairs = synthetic(count)
        vec_s, result = median_time(prune_pairs, args.runs, scene, edits, pairs)
        pre_s, prebuilt = median_time(prebuilt_loop, args.runs, scene, edits, pairs)
        naive_s, naive = median_time(naive_loop, max(1, args.runs // 2), scene, edits, pairs)
        same = result.deleted == prebuilt == naive
        print(f"{count:>8} {len(pairs):>8} {len(result.deleted):>8} {vec_s:>13.4f} "
              f"{pre_s:>11.4f} {naive_s:>9.3f} {naive_s / vec_s:>9.1f}x {str(same):>5}")
        if not same:
            raise SystemExit(f"deletions differ for {count} cameras")


if __name__ == "__main__":
    main()
