"""A synthetic COLMAP workspace at editor scale, written with pycolmap (no pixels, no matching):
N cameras walking a rectangular hall loop, looking at its walls, a dense point cloud on the walls
and floor, each image's keypoints = the points it sees, each camera verified with its capture-order
neighbours (inliers = the points both see). For the rule, scene and editor benchmarks at 1,000
cameras, where a rendered capture would take an hour to reconstruct on this machine.

    .venv/bin/python benchmarks/synthetic_workspace.py OUT_DIR [--cameras 1000] [--points 200000]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import PIL.Image  # noqa: F401  (before pycolmap: see the Pillow pitfall in cli.py)
import pycolmap

from guided_sfm.core.workspace import Workspace
from guided_sfm.sample.geometry import look

FOCAL, WIDTH, HEIGHT = 500.0, 640, 480
SPACING_M, HALL_WIDTH_M, EYE_M = 0.4, 8.0, 1.5
OBSERVATIONS_PER_IMAGE = 400  # keypoints with a 3D point per image (real: a few hundred to 2,000)
PARTNERS = 30  # verified pairs per image along capture order (retrieval's ~30)
MIN_INLIERS = 15


def walk(count: int, rng: np.random.Generator) -> tuple[list[tuple[np.ndarray, float]], float]:
    """(centre, yaw) of each camera along the hall's loop, facing the nearer long wall; the length."""
    length = count * SPACING_M / 2
    poses = []
    for i in range(count):
        out = i < count // 2
        x = (i if out else count - 1 - i) * SPACING_M + rng.uniform(-0.05, 0.05)
        y = HALL_WIDTH_M / 2 + (0.5 if out else -0.5)
        poses.append((np.array([x, y, EYE_M]), (90.0 if out else -90.0) + rng.uniform(-20, 20)))
    return poses, length


def cloud(points: int, length: float, rng: np.random.Generator) -> np.ndarray:
    """Points on the two long walls (80%) and the floor."""
    walls = int(points * 0.8)
    x = rng.uniform(-1, length + 1, points)
    y = np.where(rng.random(points) < 0.5, 0.0, HALL_WIDTH_M) + rng.normal(0, 0.02, points)
    z = rng.uniform(0, 3, points)
    floor = slice(walls, points)
    y[floor], z[floor] = rng.uniform(0, HALL_WIDTH_M, points - walls), 0.0
    return np.column_stack([x, y, z])


def visible(rotation: np.ndarray, translation: np.ndarray, xyz: np.ndarray,
            score: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(point indices, pixels) of the OBSERVATIONS_PER_IMAGE points this camera sees best (a fixed
    score per point, so neighbours detect the same ones, as a feature detector would)."""
    centre = -rotation.T @ translation
    near = np.flatnonzero(np.abs(xyz[:, 0] - centre[0]) < 10.0)
    cam = xyz[near] @ rotation.T + translation
    with np.errstate(divide="ignore", invalid="ignore"):
        pixels = FOCAL * cam[:, :2] / cam[:, 2:] + [WIDTH / 2, HEIGHT / 2]
    inside = np.flatnonzero((cam[:, 2] > 0.3) & np.all((pixels >= 0) & (pixels < [WIDTH, HEIGHT]), axis=1))
    chosen = np.sort(inside[np.argsort(score[near[inside]])[:OBSERVATIONS_PER_IMAGE]])
    return near[chosen], pixels[chosen]


def observe(count: int, points: int, seed: int):
    """Poses, the cloud, and per image (point indices, pixels)."""
    rng = np.random.default_rng(seed)
    poses, length = walk(count, rng)
    xyz = cloud(points, length, rng)
    score = rng.random(points)
    cams = [look(centre, yaw, -5.0) for centre, yaw in poses]
    return cams, xyz, [visible(r, t, xyz, score) for r, t in cams]


def write_model(folder: Path, cams, xyz: np.ndarray, seen) -> None:
    """sparse/0: one pinhole camera, every image registered, every point (tracks where seen)."""
    model = pycolmap.Reconstruction()
    model.add_camera_with_trivial_rig(pycolmap.Camera.create_from_model_name(
        1, "SIMPLE_PINHOLE", FOCAL, WIDTH, HEIGHT))
    tracks = [pycolmap.Track() for _ in range(len(xyz))]
    for index, ((rotation, translation), (ids, pixels)) in enumerate(zip(cams, seen, strict=True)):
        image = pycolmap.Image(name=f"{index:05d}.jpg", keypoints=pixels, camera_id=1,
                               image_id=index + 1)
        model.add_image_with_trivial_frame(image, pycolmap.Rigid3d(pycolmap.Rotation3d(rotation),
                                                                   translation))
        for point2d, point in enumerate(ids.tolist()):
            tracks[point].add_element(index + 1, point2d)
    for point, track in zip(xyz, tracks, strict=True):
        model.add_point3D(point, track)
    folder.mkdir(parents=True, exist_ok=True)
    model.write_binary(folder)


def write_database(path: Path, count: int, seen) -> int:
    """Cameras, images, keypoints and the verified pairs (inlier matches = shared points)."""
    db = pycolmap.Database.open(str(path))
    db.write_camera(pycolmap.Camera.create_from_model_name(1, "SIMPLE_PINHOLE", FOCAL, WIDTH, HEIGHT),
                    use_camera_id=True)
    for index, (_, pixels) in enumerate(seen):
        db.write_image(pycolmap.Image(name=f"{index:05d}.jpg", camera_id=1, image_id=index + 1),
                       use_image_id=True)
        db.write_keypoints(index + 1, pixels.astype(np.float32))
    written = 0
    for a in range(count):
        for b in range(a + 1, min(count, a + PARTNERS // 2 + 1)):
            _, ia, ib = np.intersect1d(seen[a][0], seen[b][0], return_indices=True)
            if len(ia) >= MIN_INLIERS:
                matches = np.column_stack([ia, ib]).astype(np.uint32)
                db.write_matches(a + 1, b + 1, matches)
                geometry = pycolmap.TwoViewGeometry()
                geometry.config = pycolmap.TwoViewGeometryConfiguration.CALIBRATED
                geometry.inlier_matches = matches
                db.write_two_view_geometry(a + 1, b + 1, geometry)
                written += 1
    db.close()
    return written


def write_workspace(root: Path, cameras: int = 1000, points: int = 200_000, seed: int = 0) -> dict:
    """The workspace at root (database.db, sparse/0, scene.json, images/ left empty); its figures."""
    start = time.perf_counter()
    cams, xyz, seen = observe(cameras, points, seed)
    workspace = Workspace(root)
    root.mkdir(parents=True, exist_ok=True)
    (root / "images").mkdir(exist_ok=True)
    workspace.write_meta({"image_dir": str((root / "images").resolve()), "synthetic": True})
    pairs = write_database(workspace.database, cameras, seen)
    write_model(workspace.model_dir(), cams, xyz, seen)
    workspace.write_scene()
    return {"cameras": cameras, "points": points, "pairs": pairs,
            "seconds": round(time.perf_counter() - start, 1)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", type=Path)
    parser.add_argument("--cameras", type=int, default=1000)
    parser.add_argument("--points", type=int, default=200_000)
    args = parser.parse_args()
    print(write_workspace(args.out, args.cameras, args.points))


if __name__ == "__main__":
    main()
