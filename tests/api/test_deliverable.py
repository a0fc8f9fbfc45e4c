"""The deliverable: publish a version (shown on the project list) and export it for nerfstudio
(transforms.json read the way nerfstudio reads it lands the model's points on COLMAP's own
keypoints) or as a COLMAP text model."""

import io
import json
import struct
import zipfile

import numpy as np
import pycolmap


def vurl(s, suffix):
    return f"/api/v1/projects/{s.pid}/versions/{s.vid}{suffix}"


def export(client, s, fmt):
    response = client.get(vurl(s, f"/export?format={fmt}"), headers=s.owner)
    assert response.status_code == 200, response.text
    return zipfile.ZipFile(io.BytesIO(response.content))


def project_like_nerfstudio(document, frame, world_points):
    """Pixels of COLMAP-world points through a frame, as nerfstudio's dataparser and cameras read
    it: world turned by applied_transform, camera-to-world in OpenGL axes (y up, looking down -z),
    OPENCV distortion."""
    applied = np.vstack([np.array(document["applied_transform"]), [0, 0, 0, 1]])
    world = (applied @ np.c_[world_points, np.ones(len(world_points))].T)
    cam = np.linalg.inv(np.array(frame["transform_matrix"])) @ world
    x, y, z = cam[0], -cam[1], -cam[2]  # OpenGL -> pixel axes (y down, z forward)
    u, v = x / z, y / z
    r2 = u * u + v * v
    k1, k2, p1, p2 = (frame[k] for k in ("k1", "k2", "p1", "p2"))
    radial = 1 + k1 * r2 + k2 * r2 * r2
    du = u * radial + 2 * p1 * u * v + p2 * (r2 + 2 * u * u)
    dv = v * radial + p1 * (r2 + 2 * v * v) + 2 * p2 * u * v
    return np.c_[frame["fl_x"] * du + frame["cx"], frame["fl_y"] * dv + frame["cy"]], z


def test_nerfstudio_cameras_land_the_points_on_colmaps_keypoints(client, reconstructed, tiny_reconstruction):
    s = reconstructed
    archive = export(client, s, "nerfstudio")
    document = json.loads(archive.read("transforms.json"))
    model = pycolmap.Reconstruction(str(tiny_reconstruction / "sparse" / "0"))
    registered = {i.name: i for i in model.images.values() if i.has_pose}
    assert sorted(f["file_path"] for f in document["frames"]) == sorted(f"images/{n}" for n in registered)
    names = set(archive.namelist())
    assert {f["file_path"] for f in document["frames"]} <= names and "sparse_pc.ply" in names
    assert document["ply_file_path"] == "sparse_pc.ply" and document["camera_model"] == "OPENCV"
    worst, checked = 0.0, 0
    for frame in document["frames"]:
        image = registered[frame["file_path"].removeprefix("images/")]
        assert (frame["w"], frame["h"]) == (image.camera.width, image.camera.height)
        observed = [p for p in image.points2D if p.has_point3D()]
        xyz = np.array([model.points3D[p.point3D_id].xyz for p in observed])
        pixels, depth = project_like_nerfstudio(document, frame, xyz)
        assert (depth > 0).all()  # in front of the camera
        errors = np.linalg.norm(pixels - np.array([p.xy for p in observed]), axis=1)
        worst, checked = max(worst, float(np.percentile(errors, 95))), checked + len(errors)
        # and COLMAP's own projection of the same points, to rounding
        colmap = np.array([image.project_point(p) for p in xyz])
        assert np.abs(pixels - colmap).max() < 1e-3
    print(f"nerfstudio reprojection onto keypoints: 95th percentile {worst:.3f} px over {checked}")
    assert checked > 100 and worst < 1.0, (worst, checked)


def read_ply(data):
    header, _, body = data.partition(b"end_header\n")
    count = int(next(line.split()[-1] for line in header.decode().splitlines() if line.startswith("element")))
    return [struct.unpack_from("<fffBBB", body, 15 * i) for i in range(count)]


def test_nerfstudio_point_cloud_is_in_the_frames_world(client, reconstructed, tiny_reconstruction):
    s = reconstructed
    archive = export(client, s, "nerfstudio")
    applied = np.array(json.loads(archive.read("transforms.json"))["applied_transform"])
    model = pycolmap.Reconstruction(str(tiny_reconstruction / "sparse" / "0"))
    rows = read_ply(archive.read("sparse_pc.ply"))
    assert len(rows) == len(model.points3D)
    for row, point_id in zip(rows, sorted(model.points3D), strict=True):
        point = model.points3D[point_id]
        assert np.allclose(row[:3], applied[:, :3] @ point.xyz + applied[:, 3], atol=1e-4)
        assert tuple(row[3:]) == tuple(int(c) for c in point.color)


def test_colmap_text_export_reads_back(client, reconstructed, tiny_reconstruction, tmp_path):
    s = reconstructed
    archive = export(client, s, "colmap_text")
    assert sorted(archive.namelist()) == ["cameras.txt", "images.txt", "points3D.txt"]
    archive.extractall(tmp_path)
    model = pycolmap.Reconstruction(str(tmp_path))
    original = pycolmap.Reconstruction(str(tiny_reconstruction / "sparse" / "0"))
    assert model.num_reg_images() == original.num_reg_images()
    assert model.num_points3D() == original.num_points3D()


def test_publish_shows_on_the_project_list(client, reconstructed):
    s = reconstructed
    assert client.get("/api/v1/projects", headers=s.owner).json()[0]["published_version_id"] is None
    response = client.post(vurl(s, "/publish"), headers=s.owner)
    assert response.status_code == 200 and response.json()["published_version_id"] == s.vid
    assert client.get("/api/v1/projects", headers=s.owner).json()[0]["published_version_id"] == s.vid
    missing = client.post(f"/api/v1/projects/{s.pid}/versions/999999/publish", headers=s.owner)
    assert missing.status_code == 404
