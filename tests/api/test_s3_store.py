"""The API and its jobs on the S3 store (moto's server over HTTP): uploads land in the bucket and
nowhere on disk, a batch sent again adds nothing, thumbnails are made again from the stored image,
jobs check out and publish there (sharing unchanged objects), restore and exports read it."""

import io
import json
import tempfile
import zipfile

import pytest

from guided_sfm.actions import runner
from guided_sfm.api.app import create_app
from guided_sfm.db.models import Project, Version
from guided_sfm.storage import open_store
from tests.conftest import TestClient, make_settings
from tests.factories import jpeg_bytes, make_project, signup
from tests.s3server import CREDENTIALS


@pytest.fixture
def s3_client(tmp_path, database_url, sessions, moto_server, monkeypatch):
    for name, value in CREDENTIALS.items():
        monkeypatch.setenv(name, value)
    monkeypatch.setenv("TMPDIR", str(tmp_path / "tmp"))
    monkeypatch.setattr(tempfile, "tempdir", None)  # re-read TMPDIR: the store's scratch goes there
    (tmp_path / "tmp").mkdir()
    bucket = moto_server.new_bucket()
    settings = make_settings(tmp_path / "data", database_url, artifacts_url=f"s3://{bucket}/art",
                             s3_endpoint_url=moto_server.url)
    with TestClient(create_app(settings, lambda _job: None, sessions=sessions)) as client:
        yield client, bucket, settings, tmp_path / "tmp"


def test_images_live_in_the_bucket_only(s3_client, moto_server):
    client, bucket, settings, scratch = s3_client
    owner = signup(client, "owner")
    pid = make_project(client, owner, "s3")
    batch = [("files", (f"{n}.jpg", jpeg_bytes(color=(i, 9, 9)), "image/jpeg")) for i, n in enumerate("ab")]
    first = client.post(f"/api/v1/projects/{pid}/images", files=batch, headers=owner)
    assert first.status_code == 201, first.text
    ids = {i["name"]: i["id"] for i in first.json()}
    keys = set(moto_server.objects(bucket))
    project = f"art/projects/{pid}"
    assert keys == {f"{project}/images/a.jpg", f"{project}/images/b.jpg",
                    f"{project}/thumbs/{ids['a.jpg']}.jpg", f"{project}/thumbs/{ids['b.jpg']}.jpg"}
    assert not (settings.artifacts_dir / "projects").exists()  # nothing of the project on disk

    again = client.post(f"/api/v1/projects/{pid}/images", files=batch, headers=owner)
    assert again.status_code == 201 and all(i["already_uploaded"] for i in again.json())
    assert set(moto_server.objects(bucket)) == keys

    moto_server.client().delete_object(Bucket=bucket, Key=f"art/projects/{pid}/thumbs/{ids['a.jpg']}.jpg")
    thumb = client.get(f"/api/v1/projects/{pid}/images/{ids['a.jpg']}/thumbnail", headers=owner)
    assert thumb.status_code == 200 and thumb.content[:2] == b"\xff\xd8"  # made again, a JPEG
    original = client.get(f"/api/v1/projects/{pid}/images/{ids['b.jpg']}/file", headers=owner)
    assert original.content == jpeg_bytes(color=(1, 9, 9))

    assert client.delete(f"/api/v1/projects/{pid}/images/{ids['a.jpg']}", headers=owner).status_code == 204
    assert {k for k in moto_server.objects(bucket) if "a.jpg" in k or f"/{ids['a.jpg']}.jpg" in k} == set()
    assert (scratch / "guided-sfm-scratch").is_dir()  # the requests' scratch was here ...
    assert not [p for p in scratch.rglob("*") if p.is_file()]  # ... and is emptied



def s3_version(client, session, settings, owner, tiny_images, tiny_reconstruction) -> tuple[int, Version]:
    """A project whose images were uploaded through the API and whose head version (the tiny
    reconstruction) was published to the bucket."""
    pid = make_project(client, owner, "s3-jobs")
    files = [("files", (p.name, p.read_bytes(), "image/jpeg"))
             for p in sorted((tiny_images / "images").iterdir())]
    assert client.post(f"/api/v1/projects/{pid}/images", files=files, headers=owner).status_code == 201
    path = open_store(settings).publish(pid, tiny_reconstruction)
    base = Version(project_id=pid, kind="reconstruct", message="test", path=path, stats={}, edits=None)
    session.add(base)
    session.flush()
    session.get(Project, pid).head_version_id = base.id
    session.commit()
    return pid, base


def manifest(moto_server, bucket: str, version: Version) -> dict:
    answer = moto_server.client().get_object(Bucket=bucket, Key=f"art/{version.path}/manifest.json")
    return json.loads(answer["Body"].read())


def test_apply_runs_on_the_s3_store_and_shares_unchanged_objects(s3_client, moto_server, sessions, session,
                                                                 tiny_images, tiny_reconstruction):
    """The job checks its base out of the bucket and publishes there (no shared volume)."""
    client, bucket, settings, scratch = s3_client
    owner = signup(client, "owner")
    pid, base = s3_version(client, session, settings, owner, tiny_images, tiny_reconstruction)
    api = f"/api/v1/projects/{pid}"
    pairs = client.get(f"{api}/versions/{base.id}/pairs", headers=owner).json()
    pair = [pairs[0]["image_id1"], pairs[0]["image_id2"]]
    body = {"base_version_id": base.id, "delete_pairs": [pair]}
    edit = client.post(f"{api}/edits", json=body, headers=owner).json()
    job = client.post(f"{api}/edits/{edit['id']}/apply", json={"remap": False}, headers=owner).json()
    assert runner.run_job(sessions, settings, job["id"]) == "succeeded"
    head = client.get(api, headers=owner).json()["head_version_id"]
    after = client.get(f"{api}/versions/{head}/pairs", headers=owner).json()
    assert len(after) == len(pairs) - 1 and pair not in [[p["image_id1"], p["image_id2"]] for p in after]
    files = manifest(moto_server, bucket, session.get(Version, head))["files"]
    shared = [m for m, entry in files.items() if entry["key"].startswith(base.path + "/")]
    assert "sparse/0/points3D.bin" in shared and "database.db" not in shared  # unchanged: shared
    assert not (settings.artifacts_dir / "projects").exists()
    assert not [p for p in scratch.rglob("*") if p.is_file()]  # the job's scratch was emptied


def test_restore_and_exports_read_the_bucket(s3_client, moto_server, session, tiny_images,
                                             tiny_reconstruction):
    client, bucket, settings, _ = s3_client
    owner = signup(client, "owner")
    pid, base = s3_version(client, session, settings, owner, tiny_images, tiny_reconstruction)
    api = f"/api/v1/projects/{pid}/versions"
    restored = client.post(f"{api}/{base.id}/restore", headers=owner)
    assert restored.status_code == 201, restored.text
    copy = session.get(Version, restored.json()["id"])
    assert manifest(moto_server, bucket, copy) == manifest(moto_server, bucket, base)  # a manifest only
    for fmt, member in (("colmap", "points3D.bin"), ("nerfstudio", "transforms.json")):
        exported = client.get(f"{api}/{copy.id}/export?format={fmt}", headers=owner)
        assert exported.status_code == 200, exported.text
        assert any(n.endswith(member) for n in zipfile.ZipFile(io.BytesIO(exported.content)).namelist())
