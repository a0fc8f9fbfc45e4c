"""Rendered sample scenes: determinism, truth agrees with depth, repeated objects look identical."""

import json

import numpy as np
import pytest

from guided_sfm.core.errors import InvalidInput
from guided_sfm.sample import DEFAULT_LAYOUT, LAYOUTS, write_sample
from guided_sfm.sample.geometry import look
from guided_sfm.sample.raycast import render
from guided_sfm.sample.writer import build_layout


def _files(root):
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def _rotation(qvec):
    w, x, y, z = qvec
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def test_layout_names():
    assert DEFAULT_LAYOUT == "murals"
    assert {"murals", "office", "tiny"} <= set(LAYOUTS)


def test_unknown_layout_lists_the_valid_names(tmp_path):
    with pytest.raises(InvalidInput, match="murals.*office.*tiny"):
        write_sample(tmp_path, "nope")


def test_same_seed_same_bytes_other_seed_differs(tiny_sample, tmp_path):
    again = _files(write_sample(tmp_path / "a", "tiny", seed=0))
    assert again == _files(tiny_sample)
    other = _files(write_sample(tmp_path / "b", "tiny", seed=1))
    assert other["images/0000.jpg"] != again["images/0000.jpg"]


def test_outputs_follow_the_truth_contract(tiny_sample):
    truth = json.loads((tiny_sample / "truth.json").read_text())
    cam = truth["camera"]
    assert (truth["units"], truth["up"], truth["layout"], cam["model"]) == (
        "m",
        [0, 0, 1],
        "tiny",
        "PINHOLE",
    )
    names = sorted(p.name for p in (tiny_sample / "images").glob("*.jpg"))
    assert names == [im["name"] for im in truth["images"]] and len(names) >= 10
    depth = np.load(tiny_sample / "depth" / "0000.npy")
    assert depth.dtype == np.float32 and depth.shape == (cam["height"], cam["width"])
    for im in truth["images"]:
        r = _rotation(im["qvec"])
        np.testing.assert_allclose(r @ r.T, np.eye(3), atol=1e-9)
        np.testing.assert_allclose(-r.T @ np.array(im["tvec"]), im["center"], atol=1e-9)


@pytest.mark.parametrize("point", [(1.5, 2.99, 1.5), (6.5, 2.99, 1.6), (3.0, 2.7, 0.0), (5.0, 2.75, 0.0)])
def test_depth_agrees_with_truth_pose(tiny_sample, point):
    truth = json.loads((tiny_sample / "truth.json").read_text())
    cam = truth["camera"]
    k = np.array([[cam["fx"], 0, cam["cx"]], [0, cam["fy"], cam["cy"]], [0, 0, 1.0]])
    seen = 0
    for im in truth["images"]:
        x_cam = _rotation(im["qvec"]) @ np.array(point) + np.array(im["tvec"])
        u, v = (k @ x_cam)[:2] / x_cam[2]
        if x_cam[2] <= 0 or not (1 <= u < cam["width"] - 1 and 1 <= v < cam["height"] - 1):
            continue
        depth = np.load(tiny_sample / "depth" / im["name"].replace(".jpg", ".npy"))
        assert depth[int(v), int(u)] == pytest.approx(x_cam[2], rel=0.01), im["name"]
        seen += 1
    assert seen >= 2


def test_copies_of_the_repeated_poster_render_identically():
    layout = build_layout("tiny", seed=0)
    views = [render(layout.scene, layout.camera, look((x, 0.8, 1.5), 90.0)) for x in (1.5, 6.5)]
    (rgb_a, depth_a), (rgb_b, depth_b) = views
    h, w = depth_a.shape
    patch = np.s_[h // 2 - 30 : h // 2 + 30, w // 2 - 30 : w // 2 + 30]
    np.testing.assert_allclose(depth_a[patch], depth_b[patch], rtol=1e-6)
    assert np.abs(rgb_a[patch] - rgb_b[patch]).max() < 1e-3
    assert np.abs(rgb_a[:, :20] - rgb_b[:, :20]).mean() > 0.02  # the walls around them are unique


def test_a_scaled_camera_keeps_the_field_of_view():
    cam = build_layout("hall", seed=0).camera
    big = cam.scaled(cam.width * 25 // 4, cam.height * 25 // 4)  # 640x480 -> 4000x3000
    assert (big.width, big.height) == (cam.width * 25 // 4, cam.height * 25 // 4)
    points = np.random.default_rng(0).uniform([-2, -1.5, 1], [2, 1.5, 6], (50, 3))

    def pixels(c):
        return np.stack([c.fx * points[:, 0] / points[:, 2] + c.cx,
                         c.fy * points[:, 1] / points[:, 2] + c.cy], axis=1)

    # the same point lands at the same fraction of the image, corners included
    np.testing.assert_allclose(pixels(big) / [big.width, big.height],
                               pixels(cam) / [cam.width, cam.height], rtol=1e-12)
    with pytest.raises(ValueError, match="aspect ratio"):
        cam.scaled(4000, 2000)


def test_a_slice_at_another_resolution_is_the_same_capture(tiny_sample, tmp_path):
    truth = json.loads((tiny_sample / "truth.json").read_text())
    cam = truth["camera"]
    width, height = cam["width"] * 3 // 2, cam["height"] * 3 // 2
    out = write_sample(tmp_path / "big", "tiny", seed=0, resolution=(width, height), views=2)
    big = json.loads((out / "truth.json").read_text())
    assert big["images"] == truth["images"][:2]
    assert (big["camera"]["width"], big["camera"]["fx"]) == (width, cam["fx"] * 1.5)
    assert np.load(out / "depth" / "0001.npy").shape == (height, width)
    assert sorted(p.name for p in (out / "images").iterdir()) == ["0000.jpg", "0001.jpg"]
