"""Versions: list, scene (REST ids), pairs, restore, export, compare."""

import io
import zipfile

from guided_sfm.db.models import Job, Version


def vurl(s, vid, suffix=""):
    return f"/api/v1/projects/{s.pid}/versions/{vid}{suffix}"


def test_list_versions(client, reconstructed):
    s = reconstructed
    versions = client.get(f"/api/v1/projects/{s.pid}/versions", headers=s.owner).json()
    assert [v["id"] for v in versions] == [s.vid]
    stats = {"num_images", "num_registered", "num_models", "num_pairs", "num_points"}
    assert set(versions[0]["stats"]) == stats
    assert versions[0]["stats"]["num_images"] == 12 and versions[0]["is_head"]


def test_scene_uses_rest_image_ids(client, reconstructed):
    s = reconstructed
    scene = client.get(vurl(s, s.vid, "/scene"), headers=s.owner).json()
    assert set(scene) >= {"frame", "cameras", "points", "models"}
    assert {c["image_id"] for c in scene["cameras"]} == set(s.image_ids.values())
    assert all(s.image_ids[c["name"]] == c["image_id"] for c in scene["cameras"])
    camera = next(c for c in scene["cameras"] if c["registered"])
    assert len(camera["qvec"]) == 4 and len(camera["center"]) == 3 and camera["fov_deg"] > 0


def test_pairs_filter_by_image(client, reconstructed):
    s = reconstructed
    pairs = client.get(vurl(s, s.vid, "/pairs"), headers=s.owner).json()
    assert pairs and all(p["image_id1"] < p["image_id2"] and p["num_inliers"] > 0 for p in pairs)
    one = pairs[0]["image_id1"]
    filtered = client.get(vurl(s, s.vid, f"/pairs?image_id={one}"), headers=s.owner).json()
    assert filtered and all(one in (p["image_id1"], p["image_id2"]) for p in filtered)


def test_restore_makes_a_new_head_sharing_files(client, reconstructed, session, store):
    s = reconstructed
    response = client.post(vurl(s, s.vid, "/restore"), headers=s.owner)
    assert response.status_code == 201, response.text
    restored = response.json()
    assert restored["kind"] == "restore" and restored["parent_id"] == s.vid and restored["is_head"]
    project = client.get(f"/api/v1/projects/{s.pid}", headers=s.owner).json()
    assert project["head_version_id"] == restored["id"]
    old = store.version_dir(session.get(Version, s.vid).path) / "database.db"
    new = store.version_dir(session.get(Version, restored["id"]).path) / "database.db"
    assert old.stat().st_ino == new.stat().st_ino  # a hard link, not a copy
    assert client.get(vurl(s, restored["id"], "/scene"), headers=s.owner).status_code == 200


def test_restore_is_409_while_a_job_runs(client, reconstructed, session):
    s = reconstructed
    job = client.post(f"/api/v1/projects/{s.pid}/reconstruct", json={}, headers=s.owner).json()
    response = client.post(vurl(s, s.vid, "/restore"), headers=s.owner)
    assert response.status_code == 409 and "job" in response.json()["detail"]
    assert session.query(Version).filter_by(project_id=s.pid).count() == 1
    assert session.get(Job, job["id"]).state == "queued"


def test_export_colmap_and_ply(client, reconstructed):
    s = reconstructed
    colmap = client.get(vurl(s, s.vid, "/export?format=colmap"), headers=s.owner)
    assert colmap.status_code == 200 and colmap.headers["content-type"] == "application/zip"
    names = zipfile.ZipFile(io.BytesIO(colmap.content)).namelist()
    assert sorted(names) == ["cameras.bin", "images.bin", "points3D.bin"]
    ply = client.get(vurl(s, s.vid, "/export?format=ply"), headers=s.owner)
    assert ply.status_code == 200 and ply.content.startswith(b"ply") and b"binary" in ply.content[:200]
    assert client.get(vurl(s, s.vid, "/export?format=obj"), headers=s.owner).status_code == 422


def test_compare_with_itself_is_still(client, reconstructed):
    s = reconstructed
    response = client.get(vurl(s, s.vid, f"/compare?to={s.vid}"), headers=s.owner)
    assert response.status_code == 200, response.text
    cameras = response.json()["cameras"]
    assert cameras and all(c["image_id"] in s.image_ids.values() for c in cameras)
    assert max(c["moved"] for c in cameras) < 1e-6
    assert client.get(vurl(s, s.vid, "/compare?to=99999"), headers=s.owner).status_code == 404


def test_unknown_version_is_404(client, reconstructed):
    s = reconstructed
    for suffix in ("/scene", "/pairs", "/export", f"/compare?to={s.vid}"):
        response = client.get(vurl(s, 99999, suffix), headers=s.owner)
        assert response.status_code == 404 and "version 99999" in response.json()["detail"]
