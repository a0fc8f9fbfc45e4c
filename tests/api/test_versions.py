"""Versions: list, scene (REST ids), pairs, restore, export, compare."""

import io
import shutil
import zipfile
from pathlib import Path

import numpy as np
import pycolmap

from guided_sfm.core.workspace import Workspace
from guided_sfm.db.models import Job, Version
from guided_sfm.storage import link_tree


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


def moved_workspace(source: Path, target: Path, name: str, shift: float, turn_deg: float) -> Path:
    """A copy of `source` whose model is scaled by 2, turned and shifted (what compare must undo),
    with camera `name` then moved by `shift` along world x and turned by `turn_deg` about its own y."""
    shutil.copytree(source, target)
    model = pycolmap.Reconstruction(target / "sparse" / "0")
    frame = pycolmap.Sim3d(2.0, pycolmap.Rotation3d(rotation_z(30.0)), np.array([[1.0], [2.0], [3.0]]))
    model.transform(frame)
    image = next(i for i in model.images.values() if i.name == name)
    cam_from_world = image.cam_from_world()
    center = cam_from_world.inverse().translation + np.array([shift, 0.0, 0.0])
    c, s = np.cos(np.radians(turn_deg)), np.sin(np.radians(turn_deg))
    turn = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])  # about the camera's y axis
    rotation = turn @ cam_from_world.rotation.matrix()
    moved = pycolmap.Rigid3d(pycolmap.Rotation3d(rotation), (-rotation @ center).reshape(3, 1))
    model.frame(image.frame_id).set_cam_from_world(image.camera_id, moved)
    model.write(target / "sparse" / "0")
    return target


def rotation_z(degrees: float) -> np.ndarray:
    c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def publish_version(session, store, pid: int, workspace: Path) -> int:
    """A new head version of the project from `workspace` (its images are already rows)."""
    with store.staging(pid) as staging:
        link_tree(workspace, staging / "ws")
        Workspace(staging / "ws").write_meta({"image_dir": str(store.images_dir(pid))})
        relative = store.publish(pid, staging / "ws")
    version = Version(project_id=pid, kind="reconstruct", message="moved by a test", path=relative,
                      stats=Workspace(workspace).stats())
    session.add(version)
    session.commit()
    return version.id


def test_compare_undoes_the_frame_and_finds_the_moved_camera(client, session, store, reconstructed,
                                                            tiny_reconstruction, tmp_path):
    s = reconstructed
    name = sorted(s.image_ids)[5]
    shift = 4.0  # units of the moved copy: far beyond the alignment's inlier band (2% of the extent)
    other = publish_version(session, store, s.pid,
                            moved_workspace(tiny_reconstruction, tmp_path / "ws", name, shift, 10.0))
    response = client.get(vurl(s, s.vid, f"/compare?to={other}"), headers=s.owner)
    assert response.status_code == 200, response.text
    cameras = {c["image_id"]: c for c in response.json()["cameras"]}
    assert set(cameras) == set(s.image_ids.values())
    moved = cameras.pop(s.image_ids[name])
    # in the first version's units (the copy is twice as large), after undoing the similarity
    assert abs(moved["moved"] - shift / 2) < 1e-3 and abs(moved["rotated_deg"] - 10.0) < 1e-3
    assert max(c["moved"] for c in cameras.values()) < 1e-6
    assert max(c["rotated_deg"] for c in cameras.values()) < 1e-4
    itself = client.get(vurl(s, s.vid, f"/compare?to={s.vid}"), headers=s.owner).json()["cameras"]
    assert max(c["moved"] for c in itself) < 1e-6
    assert client.get(vurl(s, s.vid, "/compare?to=99999"), headers=s.owner).status_code == 404


def test_unknown_version_is_404(client, reconstructed):
    s = reconstructed
    for suffix in ("/scene", "/pairs", "/export", f"/compare?to={s.vid}"):
        response = client.get(vurl(s, 99999, suffix), headers=s.owner)
        assert response.status_code == 404 and "version 99999" in response.json()["detail"]


def shifted_copy(source, target, moved_names, shift, sim):
    """The source workspace with the named cameras' centres shifted by `shift` (one run moved as
    one) and the whole model then re-centred by the similarity `sim`, as a re-map may do."""
    import json
    import shutil

    import pycolmap

    shutil.copytree(source, target)
    model = pycolmap.Reconstruction(target / "sparse" / "0")
    moved_ids = []
    for image_id in model.reg_image_ids():
        image = model.image(image_id)
        if image.name in moved_names:
            frame = model.frame(image.frame_id)  # one camera per frame: rig_from_world = cam_from_world
            pose = frame.rig_from_world
            frame.rig_from_world = pycolmap.Rigid3d(pose.rotation,
                                                    pose.translation - pose.rotation.matrix() @ shift)
            moved_ids.append(image_id)
    model.transform(sim)
    model.write_binary(target / "sparse" / "0")
    (target / "scene.json").unlink(missing_ok=True)
    (target / "edits.json").write_text(json.dumps({"cameras": [{"image_id": i} for i in moved_ids]}))


def test_compare_aligns_on_the_cameras_no_edit_moved(client, reconstructed, session, store,
                                                      tiny_reconstruction, tmp_path):
    """A run of most cameras moved as one, then the model re-centred: compare still aligns on
    the untouched cameras and reports exactly the moved run as moved."""
    import numpy as np
    import pycolmap

    from guided_sfm.core.workspace import Workspace

    s = reconstructed
    model = pycolmap.Reconstruction(tiny_reconstruction / "sparse" / "0")
    names = sorted(model.image(i).name for i in model.reg_image_ids())
    run = set(names[: len(names) * 2 // 3])  # the moved run outnumbers the untouched cameras
    extent = np.ptp(np.array([model.image(i).projection_center() for i in model.reg_image_ids()]), axis=0)
    sim = pycolmap.Sim3d(1.7, pycolmap.Rotation3d(np.array([0.0, 0.0, 0.38268343, 0.92387953])),
                         np.array([[5.0], [-3.0], [2.0]]))
    with store.staging(s.pid) as staging:
        shifted_copy(tiny_reconstruction, staging / "ws", run, 0.5 * float(extent.max()) * np.ones(3), sim)
        path = store.publish(s.pid, staging / "ws")
    after = Version(project_id=s.pid, parent_id=s.vid, kind="apply", message="moved a run", path=path,
                    stats=Workspace(store.version_dir(path)).stats())
    session.add(after)
    session.commit()
    for a, b in ((s.vid, after.id), (after.id, s.vid)):
        response = client.get(vurl(s, a, f"/compare?to={b}"), headers=s.owner)
        assert response.status_code == 200, response.text
        name_of = {rest_id: name for name, rest_id in s.image_ids.items()}
        by_name = {name_of[c["image_id"]]: c for c in response.json()["cameras"]}
        moved = {name for name, c in by_name.items() if c["moved"] > 0.05 * float(extent.max())}
        assert moved == run, (a, b, sorted(moved))
        assert max(by_name[n]["moved"] for n in set(names) - run) < 1e-3 * float(extent.max())


def test_delete_an_image_no_version_uses_and_refuse_one_a_version_uses(client, reconstructed, settings):
    from tests.factories import jpeg_bytes

    s = reconstructed
    base = f"/api/v1/projects/{s.pid}/images"
    files = [("files", ("zz-late.jpg", jpeg_bytes(), "image/jpeg"))]
    [late] = client.post(base, files=files, headers=s.owner).json()
    used = s.image_ids[sorted(s.image_ids)[0]]
    refused = client.delete(f"{base}/{used}", headers=s.owner)
    assert refused.status_code == 409 and f"v{s.vid}" in refused.json()["detail"], refused.text
    assert client.delete(f"{base}/{late['id']}", headers=s.owner).status_code == 204
    listed = client.get(base, headers=s.owner).json()
    assert late["id"] not in [i["id"] for i in listed] and used in [i["id"] for i in listed]
    assert [i["seq"] for i in sorted(listed, key=lambda i: i["seq"])] == list(range(len(listed)))
    assert not (settings.artifacts_dir / "projects" / str(s.pid) / "images" / "zz-late.jpg").exists()
    assert client.delete(f"{base}/{late['id']}", headers=s.owner).status_code == 404
