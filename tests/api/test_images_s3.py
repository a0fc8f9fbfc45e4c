"""Images through the API with the S3 store (moto's server over HTTP): an upload lands in the
bucket and nowhere on disk, a batch sent again adds nothing, a thumbnail is made again from the
stored image, a deleted image leaves no object."""

import tempfile

import pytest

from guided_sfm.api.app import create_app
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
