"""The scene's point layer at a level of detail the server chooses, and more on request
(issue 22: edits interactive at 1,000 cameras)."""

import numpy as np

from guided_sfm.actions import version_data


def scene_url(s, query: str = "") -> str:
    return f"/api/v1/projects/{s.pid}/versions/{s.vid}/scene{query}"


def test_a_small_scene_sends_every_kept_point_and_says_how_many(client, reconstructed):
    scene = client.get(scene_url(reconstructed), headers=reconstructed.owner).json()
    points = scene["points"]
    assert len(points["xy"]) == points["total"] > 100
    assert points["max_points"] == version_data.FULL_POINTS and points["cell"] == 0


def test_max_points_asks_for_a_coarser_layer_of_the_same_points(client, reconstructed):
    s = reconstructed
    full = client.get(scene_url(s), headers=s.owner)
    coarse = client.get(scene_url(s, "?max_points=40"), headers=s.owner)
    assert coarse.status_code == 200, coarse.text
    assert coarse.headers["etag"] != full.headers["etag"]  # a cached full layer is not reused
    points, every = coarse.json()["points"], full.json()["points"]
    assert 0 < len(points["xy"]) <= 40 and points["cell"] > 0 and points["max_points"] == 40
    assert points["total"] == every["total"]
    kept = {tuple(p) for p in every["xy"]}
    assert all(tuple(p) in kept for p in points["xy"])  # a subset, not new points
    assert coarse.json()["cameras"] == full.json()["cameras"]


def test_the_coarse_layer_covers_the_scene_as_the_full_one_does(client, reconstructed):
    s = reconstructed
    every = np.array(client.get(scene_url(s), headers=s.owner).json()["points"]["xy"])
    coarse = np.array(client.get(scene_url(s, "?max_points=60"), headers=s.owner).json()["points"]["xy"])
    cell = client.get(scene_url(s, "?max_points=60"), headers=s.owner).json()["points"]["cell"]
    # every full point has a kept point within its grid cell's diagonal: no region is dropped
    gaps = np.min(np.linalg.norm(every[:, None, :] - coarse[None, :, :], axis=2), axis=1)
    assert gaps.max() <= cell * np.sqrt(2) + 1e-9


def test_max_points_out_of_range_is_422(client, reconstructed):
    for value in (0, version_data.FULL_POINTS + 1, "many"):
        response = client.get(scene_url(reconstructed, f"?max_points={value}"),
                              headers=reconstructed.owner)
        assert response.status_code == 422, (value, response.text)


def test_a_large_scene_gets_the_smaller_default_level(client, reconstructed, monkeypatch):
    # the tiny scene stands in for one above the threshold: the rule, not the size, is tested
    monkeypatch.setattr(version_data, "LARGE_SCENE_CAMERAS", 1)
    monkeypatch.setattr(version_data, "LARGE_SCENE_POINTS", 30)
    points = client.get(scene_url(reconstructed), headers=reconstructed.owner).json()["points"]
    assert len(points["xy"]) <= 30 < points["total"] and points["max_points"] == 30
    assert version_data.point_budget(1) == version_data.FULL_POINTS


def test_the_level_is_gzipped_too(client, reconstructed):
    s = reconstructed
    response = client.get(scene_url(s, "?max_points=50"), headers={**s.owner, "Accept-Encoding": "gzip"})
    assert response.headers.get("content-encoding") == "gzip"
    assert len(response.json()["points"]["xy"]) <= 50
