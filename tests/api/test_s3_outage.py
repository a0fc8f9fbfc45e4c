"""The S3 store unavailable (its endpoint refusing connections, answering 503 SlowDown, or never
there): the API answers 503 naming the artifact store, never 500, and stores nothing; once the
store is back the API answers again. A TCP gate in front of moto's server takes the store away
while the server keeps its objects."""

import contextlib
import tempfile
import time

import pytest

from guided_sfm.api.app import create_app
from guided_sfm.db.models import Project, Version
from guided_sfm.storage import open_store
from tests.conftest import TestClient, make_settings
from tests.factories import jpeg_bytes, make_project, signup
from tests.s3server import CREDENTIALS, Gate, free_port


@pytest.fixture
def s3_env(tmp_path, monkeypatch):
    for name, value in CREDENTIALS.items():
        monkeypatch.setenv(name, value)
    monkeypatch.setenv("TMPDIR", str(tmp_path / "tmp"))
    monkeypatch.setattr(tempfile, "tempdir", None)  # re-read TMPDIR: the store's scratch goes there
    (tmp_path / "tmp").mkdir()


def _client(tmp_path, database_url, sessions, artifacts_url: str, endpoint: str) -> TestClient:
    settings = make_settings(tmp_path / "data", database_url, artifacts_url=artifacts_url,
                             s3_endpoint_url=endpoint)
    return TestClient(create_app(settings, lambda _job: None, sessions=sessions))


def _unavailable(response) -> bool:
    return response.status_code == 503 and "artifact store unavailable" in response.json()["detail"]


def _upload(client, headers, pid, name="a.jpg"):
    files = [("files", (name, jpeg_bytes(), "image/jpeg"))]
    return client.post(f"/api/v1/projects/{pid}/images", files=files, headers=headers)


@contextlib.contextmanager
def _project_behind_gate(tmp_path, database_url, sessions, moto_server):
    """(client, gate, bucket, owner, project id, image) on a bucket reached through a gate."""
    gate, bucket = Gate(moto_server.port), moto_server.new_bucket()
    try:
        with _client(tmp_path, database_url, sessions, f"s3://{bucket}/art", gate.url) as client:
            owner = signup(client, "owner")
            pid = make_project(client, owner)
            image = _upload(client, owner, pid).json()[0]
            yield client, gate, bucket, owner, pid, image
    finally:
        gate.close()


def test_an_endpoint_nobody_answers_is_503_and_stores_nothing(tmp_path, database_url, sessions, s3_env):
    nobody = f"http://127.0.0.1:{free_port()}"  # a port nothing listens on
    with _client(tmp_path, database_url, sessions, "s3://bucket/art", nobody) as client:
        owner = signup(client, "owner")
        answer = client.post("/api/v1/projects", json={"name": "p"}, headers=owner)  # clears its keys
        assert _unavailable(answer), answer.text
        assert client.get("/api/v1/projects", headers=owner).json() == []


@pytest.mark.parametrize("fault", ["close", "busy"])
def test_a_store_that_goes_away_is_503_and_nothing_changes(fault, tmp_path, database_url, sessions, session,
                                                          s3_env, moto_server, tiny_reconstruction):
    with _project_behind_gate(tmp_path, database_url, sessions, moto_server) as (client, gate, bucket,
                                                                             owner, pid, image):
        path = open_store(client.app.state.settings).publish(pid, tiny_reconstruction)
        version = Version(project_id=pid, kind="reconstruct", message="t", path=path, stats={})
        session.add(version)
        session.flush()
        session.get(Project, pid).head_version_id = version.id
        session.commit()
        keys = set(moto_server.objects(bucket))
        getattr(gate, fault)()

        api = f"/api/v1/projects/{pid}"
        for path in (f"{api}/images/{image['id']}/thumbnail", f"{api}/images/{image['id']}/file",
                     f"{api}/versions/{version.id}/scene", f"{api}/versions/{version.id}/pairs"):
            answer = client.get(path, headers=owner)
            assert _unavailable(answer), (path, answer.status_code, answer.text)
        assert _unavailable(_upload(client, owner, pid, "b.jpg"))
        assert _unavailable(client.post(f"{api}/versions/{version.id}/restore", headers=owner))
        assert [i["name"] for i in client.get(f"{api}/images", headers=owner).json()] == ["a.jpg"]
        assert [v["id"] for v in client.get(f"{api}/versions", headers=owner).json()] == [version.id]
        assert set(moto_server.objects(bucket)) == keys  # nothing stored, nothing lost

        gate.open()
        assert client.get(f"{api}/images/{image['id']}/thumbnail", headers=owner).status_code == 200
        assert _upload(client, owner, pid, "b.jpg").status_code == 201


@pytest.mark.parametrize("what", ["project", "image"])
def test_a_delete_committed_before_the_store_went_away_is_204_and_the_files_are_collected_later(
        what, tmp_path, database_url, sessions, s3_env, moto_server):
    """The rows go first (one commit), then the files: a store away at that moment cannot undo the
    commit, so the answer is the delete's 204 (a 503 'nothing was stored, retry' would be a lie:
    the retry is a 404), and the files are the reconciler's orphans."""
    with _project_behind_gate(tmp_path, database_url, sessions, moto_server) as (client, gate, bucket,
                                                                             owner, pid, image):
        gate.close()
        api = f"/api/v1/projects/{pid}"
        path = api if what == "project" else f"{api}/images/{image['id']}"
        answer = client.delete(path, headers=owner)
        assert answer.status_code == 204, answer.text
        assert client.get(path if what == "project" else f"{api}/images", headers=owner).status_code \
            == (404 if what == "project" else 200)
        if what == "image":
            assert client.get(f"{api}/images", headers=owner).json() == []
        assert any(key.endswith("/a.jpg") for key in moto_server.objects(bucket))  # left for later


def test_an_endpoint_that_answers_nothing_is_503_within_its_read_timeout(tmp_path, database_url, sessions,
                                                                         s3_env, moto_server, monkeypatch):
    """Connected, then silent (a hung server or proxy): each try ends at the read timeout, so the
    request ends as a 503 after the tries, not after botocore's default 60 s a try."""
    from guided_sfm.storage import s3

    monkeypatch.setattr(s3, "READ_SECONDS", 1)
    with _project_behind_gate(tmp_path, database_url, sessions, moto_server) as (client, gate, _, owner,
                                                                             pid, image):
        gate.hang()
        start = time.monotonic()
        answer = client.get(f"/api/v1/projects/{pid}/images/{image['id']}/file", headers=owner)
        assert _unavailable(answer), answer.text
        assert time.monotonic() - start < 30


def test_readiness_names_an_s3_store_that_is_away_or_refuses_writes(tmp_path, database_url, sessions, s3_env,
                                                                    moto_server):
    """/health/ready writes a probe: a closed endpoint, one answering 503 SlowDown and a bucket
    that is not there are each 503 naming the store; the store back is ready again."""
    gate, bucket = Gate(moto_server.port), moto_server.new_bucket()
    try:
        with _client(tmp_path, database_url, sessions, f"s3://{bucket}/art", gate.url) as client:
            assert client.get("/api/v1/health/ready").json() == {"status": "ready"}
            for fault in (gate.close, gate.busy):
                fault()
                response = client.get("/api/v1/health/ready")
                assert response.status_code == 503 and response.json()["down"] == ["store"], response.text
                assert "artifact store unavailable" in response.json()["detail"]
                assert client.get("/api/v1/health").status_code == 200  # liveness: API and database
            gate.open()
            assert client.get("/api/v1/health/ready").json() == {"status": "ready"}
        with _client(tmp_path, database_url, sessions, "s3://no-such-bucket/art", gate.url) as client:
            response = client.get("/api/v1/health/ready")
            assert response.status_code == 503 and response.json()["down"] == ["store"], response.text
            assert "NoSuchBucket" in response.json()["detail"]
    finally:
        gate.close()
