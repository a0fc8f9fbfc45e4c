"""The smaller items of hardening: 4xx not 5xx on odd input, no server paths in errors, security
headers, opt-in paging, a database file only its owner reads."""

import os

from sqlalchemy import text

from guided_sfm.db.models import Version
from guided_sfm.db.session import make_engine
from tests.factories import jpeg_bytes, make_project, signup


def test_huge_if_match_and_long_utf8_names_are_4xx(client, session):
    owner = signup(client, "alice")
    pid = make_project(client, owner)
    version = Version(project_id=pid, kind="reconstruct", path="projects/none", stats={})
    session.add(version)
    session.commit()
    edits = f"/api/v1/projects/{pid}/edits"
    created = client.post(edits, json={"base_version_id": version.id}, headers=owner).json()
    response = client.put(f"{edits}/{created['id']}", json={"base_version_id": version.id},
                          headers={**owner, "If-Match": str(2**64)})
    assert response.status_code == 409, response.text
    name = "é" * 150 + ".jpg"  # 154 characters, 304 bytes: over what a file system takes
    response = client.post(f"/api/v1/projects/{pid}/images", headers=owner,
                           files=[("files", (name, jpeg_bytes(), "image/jpeg"))])
    assert response.status_code == 422 and "file name" in response.json()["detail"], response.text


def test_errors_carry_no_server_paths(client, session, settings):
    owner = signup(client, "alice")
    pid = make_project(client, owner)
    version = Version(project_id=pid, kind="reconstruct", path="projects/gone/versions/v1", stats={})
    session.add(version)
    session.commit()
    response = client.get(f"/api/v1/projects/{pid}/versions/{version.id}/scene", headers=owner)
    assert 400 <= response.status_code < 500, response.text
    assert str(settings.data_dir) not in response.text and "/versions/" not in response.text, response.text


def test_security_headers_on_the_editor_and_the_api(client):
    for path in ("/", "/api/v1/health"):
        response = client.get(path)
        csp = response.headers["content-security-policy"]
        assert "default-src 'self'" in csp and "frame-ancestors 'none'" in csp and "unsafe" not in csp
        assert response.headers["x-content-type-options"] == "nosniff"
        assert response.headers["x-frame-options"] == "DENY"


def test_lists_page_only_when_asked(client):
    owner = signup(client, "alice")
    pid = make_project(client, owner)
    files = [("files", (f"{n}.jpg", jpeg_bytes(color=(n, 0, 0)), "image/jpeg")) for n in range(5)]
    assert client.post(f"/api/v1/projects/{pid}/images", files=files, headers=owner).status_code == 201
    url = f"/api/v1/projects/{pid}/images"
    assert [i["name"] for i in client.get(url, headers=owner).json()] == [f"{n}.jpg" for n in range(5)]
    page = client.get(url, params={"limit": 2, "offset": 1}, headers=owner).json()
    assert [i["name"] for i in page] == ["1.jpg", "2.jpg"]
    assert client.get(url, params={"limit": 0}, headers=owner).status_code == 422
    jobs = client.get(f"/api/v1/projects/{pid}/jobs", params={"limit": 1}, headers=owner)
    assert jobs.status_code == 200 and jobs.json() == []


def test_the_sqlite_file_is_readable_by_its_owner_only(tmp_path):
    engine = make_engine(f"sqlite:///{tmp_path / 'x.db'}")
    with engine.connect() as conn:
        conn.execute(text("CREATE TABLE t (x INTEGER)"))
        conn.commit()
    engine.dispose()
    for path in tmp_path.iterdir():
        assert os.stat(path).st_mode & 0o777 == 0o600, path


def test_the_scene_is_tagged_and_gzipped(client, reconstructed):
    s = reconstructed
    url = f"/api/v1/projects/{s.pid}/versions/{s.vid}/scene"
    first = client.get(url, headers={**s.owner, "Accept-Encoding": "gzip"})
    assert first.status_code == 200 and first.headers["content-encoding"] == "gzip"
    assert first.json()["cameras"]  # httpx undoes the gzip
    again = client.get(url, headers={**s.owner, "If-None-Match": first.headers["etag"]})
    assert again.status_code == 304 and again.content == b""
    assert client.get(url, headers={**s.owner, "If-None-Match": '"other"'}).status_code == 200
