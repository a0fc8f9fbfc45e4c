"""Uploads: JPEG/PNG or one zip; every bad input is a 4xx with a message and stores nothing."""

import io
import zipfile

import pytest

from guided_sfm.db.models import Image
from tests.conftest import TestClient, make_settings
from tests.factories import jpeg_bytes, make_project, signup, zip_bytes


@pytest.fixture
def owner_pid(client):
    headers = signup(client, "alice")
    return headers, make_project(client, headers)


def post(client, headers, pid, files):
    return client.post(f"/api/v1/projects/{pid}/images", files=files, headers=headers)


def assert_nothing_stored(session, settings, pid):
    assert session.query(Image).filter_by(project_id=pid).count() == 0
    project_dir = settings.artifacts_dir / "projects" / str(pid)
    assert not list((project_dir / "images").glob("*")) if (project_dir / "images").exists() else True
    assert not list((project_dir / "tmp").glob("*")) if (project_dir / "tmp").exists() else True


def test_upload_images_and_zip(client, owner_pid):
    headers, pid = owner_pid
    files = [("files", ("b.jpg", jpeg_bytes(), "image/jpeg")),
             ("files", ("a.png", jpeg_bytes(fmt="PNG"), "image/png"))]
    response = post(client, headers, pid, files)
    assert response.status_code == 201, response.text
    assert {(i["name"], i["seq"]) for i in response.json()} == {("a.png", 0), ("b.jpg", 1)}
    archive = zip_bytes({"folder/c.jpg": jpeg_bytes(), "__MACOSX/._c.jpg": b"junk", "folder/": b""})
    response = post(client, headers, pid, [("files", ("more.zip", archive, "application/zip"))])
    assert response.status_code == 201, response.text
    listed = client.get(f"/api/v1/projects/{pid}/images", headers=headers).json()
    assert [i["name"] for i in listed] == ["a.png", "b.jpg", "c.jpg"]
    original = client.get(f"/api/v1/projects/{pid}/images/{listed[0]['id']}/file", headers=headers)
    assert original.content == jpeg_bytes(fmt="PNG")


def bomb() -> bytes:
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("huge.jpg", b"\0" * (3 << 20))  # 3 MB of zeros compress to a few KB
    return buffer.getvalue()


BAD_UPLOADS = {
    "not an image": ([("files", ("notes.jpg", b"hello, not a jpeg", "image/jpeg"))], 422, "not a readable"),
    "text file": ([("files", ("notes.txt", b"hello", "text/plain"))], 422, "not a .jpg"),
    "corrupt jpeg": ([("files", ("x.jpg", jpeg_bytes(200, 200)[:300], "image/jpeg"))], 422, "not a readable"),
    "gif": ([("files", ("x.png", jpeg_bytes(fmt="GIF"), "image/png"))], 422, "GIF images are not accepted"),
    "empty file": ([("files", ("x.jpg", b"", "image/jpeg"))], 422, "empty"),
    "no files": ([], 422, "files"),
    "one bad among good": ([("files", ("a.jpg", jpeg_bytes(), "image/jpeg")),
                            ("files", ("b.jpg", b"garbage", "image/jpeg"))], 422, "b.jpg"),
    "duplicate names": ([("files", ("a.jpg", jpeg_bytes(), "image/jpeg")),
                         ("files", ("dir/a.jpg", jpeg_bytes(), "image/jpeg"))], 422, "twice"),
    "zip with ..": ([("files", ("z.zip", zip_bytes({"../evil.jpg": jpeg_bytes()}), "application/zip"))],
                    422, "'..'"),
    "zip with absolute path": ([("files", ("z.zip", zip_bytes({"/etc/evil.jpg": jpeg_bytes()}),
                                           "application/zip"))], 422, "absolute"),
    "zip bomb": ([("files", ("z.zip", bomb(), "application/zip"))], 413, "expands"),
    "oversized file": ([("files", ("big.jpg", b"\xff" * (2 << 20) + b"x", "image/jpeg"))], 413, "limit"),
    "broken zip": ([("files", ("z.zip", b"PK\x03\x04 broken", "application/zip"))], 422, "zip"),
    "zip and image": ([("files", ("z.zip", zip_bytes({"a.jpg": jpeg_bytes()}), "application/zip")),
                       ("files", ("b.jpg", jpeg_bytes(), "image/jpeg"))], 422, "exactly one .zip"),
    "empty zip": ([("files", ("z.zip", zip_bytes({}), "application/zip"))], 422, "no files"),
}


@pytest.fixture
def small_client(tmp_path, database_url, sessions):
    """The API with a 2 MB upload limit."""
    from guided_sfm.api.app import create_app

    settings = make_settings(tmp_path / "data", database_url, max_upload_mb=2)
    with TestClient(create_app(settings, lambda job_id: None, sessions=sessions)) as client:
        yield client, settings


@pytest.mark.parametrize("case", sorted(BAD_UPLOADS))
def test_bad_upload_is_refused_and_nothing_stored(small_client, session, case):
    client, settings = small_client
    headers = signup(client, "alice")
    pid = make_project(client, headers)
    files, status, words = BAD_UPLOADS[case]
    response = post(client, headers, pid, files)
    assert response.status_code == status, response.text
    assert words in response.json()["detail"]
    assert_nothing_stored(session, settings, pid)


@pytest.mark.parametrize("case", ["not an image", "corrupt jpeg", "broken zip"])
def test_an_upload_error_names_no_server_path(small_client, case):
    """The detail names the files as they were sent: no data dir, temp dir or staging name."""
    import tempfile

    client, settings = small_client
    headers = signup(client, "alice")
    pid = make_project(client, headers)
    detail = post(client, headers, pid, BAD_UPLOADS[case][0]).json()["detail"]
    sent = BAD_UPLOADS[case][0][0][1][0]
    assert detail.startswith(f"{sent}: "), detail
    for secret in (str(settings.data_dir), tempfile.gettempdir(), "upload-", "staging"):
        assert secret not in detail, detail


def test_declared_body_over_the_limit_is_413_before_reading(small_client):
    client, _ = small_client
    headers = signup(client, "alice")
    pid = make_project(client, headers)
    too_big = {**headers, "Content-Length": str(50 << 20)}
    response = client.post(f"/api/v1/projects/{pid}/images", headers=too_big, content=b"x")
    assert response.status_code == 413


def test_existing_name_is_409_and_nothing_stored(client, owner_pid, session, settings):
    """An existing name with other bytes (the same bytes are a batch sent again: see below)."""
    headers, pid = owner_pid
    assert post(client, headers, pid, [("files", ("a.jpg", jpeg_bytes(), "image/jpeg"))]).status_code == 201
    files = [("files", (name, jpeg_bytes(color=(1, 2, 3)), "image/jpeg")) for name in ("b.jpg", "a.jpg")]
    response = post(client, headers, pid, files)
    assert response.status_code == 409 and "a.jpg" in response.json()["detail"]
    assert [i.name for i in session.query(Image).filter_by(project_id=pid)] == ["a.jpg"]
    stored = settings.artifacts_dir / "projects" / str(pid) / "images"
    assert sorted(p.name for p in stored.iterdir()) == ["a.jpg"]


def test_unknown_image_is_404(client, owner_pid):
    headers, pid = owner_pid
    assert client.get(f"/api/v1/projects/{pid}/images/999/thumbnail", headers=headers).status_code == 404


def test_upload_while_an_import_is_queued_is_409_and_stores_nothing(client, owner_pid, session, settings):
    from guided_sfm.db.models import Job

    headers, pid = owner_pid
    session.add(Job(project_id=pid, kind="import", state="queued", stage="queued", params={}))
    session.commit()
    response = post(client, headers, pid, [("files", ("a.jpg", jpeg_bytes(), "image/jpeg"))])
    assert response.status_code == 409 and "import" in response.json()["detail"], response.text
    assert_nothing_stored(session, settings, pid)


def test_an_orphan_file_without_a_row_is_replaced_by_the_next_upload(client, owner_pid, session, settings):
    headers, pid = owner_pid
    orphan = settings.artifacts_dir / "projects" / str(pid) / "images" / "a.jpg"
    orphan.parent.mkdir(parents=True)
    orphan.write_bytes(b"left by a crashed upload")
    response = post(client, headers, pid, [("files", ("a.jpg", jpeg_bytes(), "image/jpeg"))])
    assert response.status_code == 201, response.text
    assert orphan.read_bytes() == jpeg_bytes()


def test_a_batch_sent_again_adds_nothing_and_answers_201(client, owner_pid, session, settings):
    """Idempotent by name and content: the lost answer of a batch is no reason for a 409."""
    headers, pid = owner_pid
    batch = [("files", (name, jpeg_bytes(color=(i, 9, 9)), "image/jpeg"))
             for i, name in enumerate(("a.jpg", "b.jpg"))]
    first = post(client, headers, pid, batch)
    assert first.status_code == 201 and not any(i["already_uploaded"] for i in first.json())
    assert all(len(i["sha256"]) == 64 for i in first.json())
    again = post(client, headers, pid, batch + [("files", ("c.jpg", jpeg_bytes(), "image/jpeg"))])
    assert again.status_code == 201, again.text
    by_name = {i["name"]: i for i in again.json()}
    assert {n: i["already_uploaded"] for n, i in by_name.items()} == {"a.jpg": True, "b.jpg": True,
                                                                        "c.jpg": False}
    assert {i["name"]: i["id"] for i in first.json()} == {n: by_name[n]["id"] for n in ("a.jpg", "b.jpg")}
    names = sorted(i.name for i in session.query(Image).filter_by(project_id=pid))
    assert names == ["a.jpg", "b.jpg", "c.jpg"]
    stored = settings.artifacts_dir / "projects" / str(pid) / "images"
    assert sorted(p.name for p in stored.iterdir()) == ["a.jpg", "b.jpg", "c.jpg"]
    uploads = client.get(f"/api/v1/projects/{pid}/activity?action=upload", headers=headers).json()
    assert [item["detail"]["count"] for item in uploads["items"]] == [1, 2]  # nothing logged twice


def test_an_image_stored_before_hashes_is_recognised_by_its_file(client, owner_pid, session):
    headers, pid = owner_pid
    files = [("files", ("old.jpg", jpeg_bytes(), "image/jpeg"))]
    assert post(client, headers, pid, files).status_code == 201
    session.query(Image).filter_by(project_id=pid).update({"sha256": None})  # as before 0006
    session.commit()
    again = post(client, headers, pid, files)
    assert again.status_code == 201 and again.json()[0]["already_uploaded"] is True
    session.expire_all()
    assert session.query(Image).filter_by(project_id=pid).one().sha256 == again.json()[0]["sha256"]
