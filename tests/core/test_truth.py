"""The ground-truth oracles on hand-made cases: cameras side by side looking down +z at a wall whose
depth is known, so every true match is a horizontal shift of fx * baseline / depth pixels."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pycolmap
import pytest

from guided_sfm.core.truth import (
    FALSE_PAIR_SHARE,
    REPROJECTION_PX,
    Truth,
    TruthCamera,
    false_pairs,
    wrong_match_share,
)

FX, CX, CY, WIDTH, HEIGHT = 100.0, 50.0, 40.0, 100, 80
NEAR, FAR = 5.0, 10.0  # the wall's depth on the image's left and right halves (metres)


def camera_at(x: float) -> TruthCamera:
    """Looking down +z from (x, 0, 0): cam_from_world is R = I, t = -centre."""
    center = np.array([x, 0.0, 0.0])
    return TruthCamera(np.eye(3), -center, center)


def make_truth(tmp_path: Path, xs: dict[str, float]) -> Truth:
    depth_dir = tmp_path / "depth"
    depth_dir.mkdir(parents=True)
    depth = np.full((HEIGHT, WIDTH), NEAR, dtype=np.float32)
    depth[:, WIDTH // 2:] = FAR  # left columns near, right columns far: rows and columns differ
    for name in xs:
        np.save(depth_dir / (Path(name).stem + ".npy"), depth)
    intrinsics = np.array([[FX, 0, CX], [0, FX, CY], [0, 0, 1]])
    return Truth(np.array([0, -1.0, 0]), {n: camera_at(x) for n, x in xs.items()}, intrinsics, depth_dir)


def grid() -> np.ndarray:
    """Ten keypoints (COLMAP pixels): four on the near half, six on the far half of the image."""
    return np.array([[u + 0.5, v + 0.5] for u in (30, 40, 60, 70, 80) for v in (20, 50)], dtype=float)


def seen_from(xy1: np.ndarray, baseline: float) -> np.ndarray:
    """Where each keypoint of the left camera lands in a camera `baseline` metres to its right."""
    depth = np.where(xy1[:, 0] < WIDTH / 2, NEAR, FAR)
    return xy1 - np.column_stack([FX * baseline / depth, np.zeros(len(xy1))])


def test_true_matches_are_right_and_the_share_counts_the_wrong(tmp_path):
    truth = make_truth(tmp_path, {"a.jpg": 0.0, "b.jpg": 1.0})
    xy1 = grid()
    xy2 = seen_from(xy1, 1.0)  # shifts of 20 px (near) and 10 px (far)
    assert wrong_match_share(truth, "a.jpg", "b.jpg", xy1, xy2) == 0.0
    off = xy2.copy()
    off[:3, 1] += REPROJECTION_PX + 1  # three matches off by more than the tolerance
    off[3:5, 0] += REPROJECTION_PX - 1  # two off by less: still right
    assert wrong_match_share(truth, "a.jpg", "b.jpg", xy1, off) == pytest.approx(0.3)
    all_near = xy1 - np.array([FX * 1.0 / NEAR, 0.0])  # as if the wall were near everywhere
    assert wrong_match_share(truth, "a.jpg", "b.jpg", xy1, all_near) == 0.6  # the 6 far ones miss


def test_no_depth_or_a_point_behind_the_second_camera_is_wrong(tmp_path):
    truth = make_truth(tmp_path, {"a.jpg": 0.0, "b.jpg": 1.0})
    np.save(truth.depth_dir / "a.npy", np.zeros((HEIGHT, WIDTH), dtype=np.float32))  # a hole
    xy1 = grid()
    assert wrong_match_share(truth, "a.jpg", "b.jpg", xy1, seen_from(xy1, 1.0)) == 1.0
    # a camera 20 m ahead of a, also looking down +z: the wall (5-10 m) is behind it, and xy2 is
    # where the pinhole maths would still put each point, so only the depth sign can say "wrong"
    ahead = TruthCamera(np.eye(3), np.array([0.0, 0.0, -20.0]), np.array([0.0, 0.0, 20.0]))
    behind = make_truth(tmp_path / "t2", {"a.jpg": 0.0})
    behind.cameras["c.jpg"] = ahead
    depth = np.where(xy1[:, 0] < WIDTH / 2, NEAR, FAR)[:, None]
    principal = np.array([CX + 0.5, CY + 0.5])
    mirrored = (xy1 - principal) * depth / (depth - 20.0) + principal
    assert wrong_match_share(behind, "a.jpg", "c.jpg", xy1, mirrored) == 1.0
    assert wrong_match_share(truth, "a.jpg", "b.jpg", np.zeros((0, 2)), np.zeros((0, 2))) == 0.0


def write_database(path: Path, names: list[str], pairs: dict[tuple[int, int], tuple[np.ndarray, np.ndarray]]):
    """A COLMAP database: one camera, the images (ids 1..n in order), each pair's keypoints
    appended to its two images and matched one to one as verified inliers."""
    keypoints: dict[int, list[np.ndarray]] = {i: [] for i in range(1, len(names) + 1)}
    matches = {}
    for (id1, id2), (xy1, xy2) in pairs.items():
        start1, start2 = sum(map(len, keypoints[id1])), sum(map(len, keypoints[id2]))
        keypoints[id1].append(xy1)
        keypoints[id2].append(xy2)
        matches[id1, id2] = np.column_stack([np.arange(len(xy1)) + start1, np.arange(len(xy2)) + start2])
    with pycolmap.Database.open(path) as db:
        camera = pycolmap.Camera.create_from_model_name(0, "PINHOLE", FX, WIDTH, HEIGHT)
        camera_id = db.write_camera(camera)
        for image_id, name in enumerate(names, start=1):
            image = pycolmap.Image(name=name, camera_id=camera_id, image_id=image_id)
            db.write_image(image, use_image_id=True)
            rows = np.vstack(keypoints[image_id] or [np.zeros((0, 2))])
            db.write_keypoints(image_id, rows.astype(np.float32))
        for (id1, id2), pair_matches in matches.items():
            geometry = pycolmap.TwoViewGeometry()
            geometry.config = 2  # calibrated
            geometry.inlier_matches = pair_matches.astype(np.uint32)
            db.write_two_view_geometry(id1, id2, geometry)


def with_wrong(xy1: np.ndarray, baseline: float, wrong: int) -> tuple[np.ndarray, np.ndarray]:
    xy2 = seen_from(xy1, baseline)
    xy2[:wrong, 1] += 3 * REPROJECTION_PX
    return xy1, xy2


def test_false_pairs_are_those_with_half_or_more_wrong(tmp_path):
    names = ["a.jpg", "b.jpg", "c.jpg", "d.jpg"]
    truth = make_truth(tmp_path, {"a.jpg": 0.0, "b.jpg": 1.0, "c.jpg": 2.0, "d.jpg": 0.5})
    assert FALSE_PAIR_SHARE == 0.5  # the cases below sit on either side of it
    pairs = {(1, 2): with_wrong(grid(), 1.0, 0), (1, 3): with_wrong(grid(), 2.0, 5),
             (2, 3): with_wrong(grid(), 1.0, 4), (1, 4): with_wrong(grid(), 0.5, 10)}
    write_database(tmp_path / "database.db", names, pairs)
    assert false_pairs(tmp_path / "database.db", truth) == {(1, 3), (1, 4)}


def test_false_pairs_need_depth_and_intrinsics(tmp_path):
    truth = make_truth(tmp_path, {"a.jpg": 0.0})
    write_database(tmp_path / "database.db", ["a.jpg"], {})
    with pytest.raises(Exception, match="no depth maps or intrinsics"):
        false_pairs(tmp_path / "database.db", Truth(truth.up, truth.cameras, None, truth.depth_dir))
