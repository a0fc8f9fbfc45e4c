"""Health as design.md pins it: liveness answers 503 when the database does not; readiness names
what is down (the database, the broker, the workers, the artifact store)."""

from guided_sfm.api.app import create_app
from guided_sfm.db.session import make_engine, make_sessionmaker
from tests.conftest import TestClient, make_settings

NOWHERE = "postgresql+psycopg://postgres@127.0.0.1:9/none?connect_timeout=2"  # port 9: nothing listens


def test_liveness_and_readiness_name_what_is_down(settings, sessions):
    up = create_app(settings, lambda _: None, sessions=sessions, readiness=dict)
    with TestClient(up) as client:
        assert client.get("/api/v1/health").json() == {"status": "ok"}
        assert client.get("/api/v1/health/ready").json() == {"status": "ready"}
    no_worker = create_app(settings, lambda _: None, sessions=sessions,
                           readiness=lambda: {"workers": "no worker seen in the last 150 s"})
    with TestClient(no_worker) as client:
        assert client.get("/api/v1/health").status_code == 200  # liveness: the API and its database
        response = client.get("/api/v1/health/ready")
        assert response.status_code == 503 and response.json()["down"] == ["workers"], response.text
        assert "no worker seen" in response.json()["detail"]
    engine = make_engine(NOWHERE)
    down = create_app(settings, lambda _: None, sessions=make_sessionmaker(engine), readiness=dict)
    with TestClient(down) as client:
        response = client.get("/api/v1/health")
        assert response.status_code == 503 and "database does not answer" in response.json()["detail"]
        response = client.get("/api/v1/health/ready")
        assert response.status_code == 503 and response.json()["down"] == ["database"], response.text
        response = client.post("/api/v1/users", json={"username": "x", "password": "long enough pw"})
        assert response.status_code == 503 and "database is unavailable" in response.json()["detail"]
        assert response.headers["retry-after"]
    engine.dispose()


def test_readiness_names_a_data_dir_store_it_cannot_write(settings, sessions):
    """The data dir's artifacts folder cannot hold a file (a file stands where the folder goes:
    this fails for root too, unlike a chmod): not ready, naming the store; liveness unchanged."""
    app = create_app(settings, lambda _: None, sessions=sessions, readiness=dict)
    with TestClient(app) as client:
        assert client.get("/api/v1/health/ready").json() == {"status": "ready"}
        settings.artifacts_dir.rmdir()  # made at the app's start (a new data dir is ready), left empty
        settings.artifacts_dir.write_bytes(b"")
        response = client.get("/api/v1/health/ready")
        assert response.status_code == 503 and response.json()["down"] == ["store"], response.text
        assert "artifact store" in response.json()["detail"]
        assert str(settings.data_dir) not in response.text  # no server paths
        assert client.get("/api/v1/health").status_code == 200


def test_readiness_names_a_data_dir_store_whose_artifacts_folder_is_gone_and_makes_none(
        tmp_path, database_url, sessions):
    """An unmounted volume has no artifacts folder: not ready, naming the store, and the probe does
    not make one (that would read as ready); the app's start makes it for a new data dir."""
    settings = make_settings(tmp_path / "data", database_url)
    assert not settings.artifacts_dir.exists()
    app = create_app(settings, lambda _: None, sessions=sessions, readiness=dict)
    assert settings.artifacts_dir.is_dir()  # made at start-up
    with TestClient(app) as client:
        assert client.get("/api/v1/health/ready").json() == {"status": "ready"}
        settings.artifacts_dir.rmdir()
        for _ in range(2):  # the first probe made nothing the second finds
            response = client.get("/api/v1/health/ready")
            assert response.status_code == 503 and response.json()["down"] == ["store"], response.text
            assert "no artifacts folder" in response.json()["detail"]
            assert str(settings.data_dir) not in response.text  # no server paths
        assert not settings.artifacts_dir.exists()
        assert client.get("/api/v1/health").status_code == 200


def test_readiness_names_a_store_it_cannot_even_ask(tmp_path, database_url, sessions, monkeypatch):
    """A bucket name S3 refuses before any request (a misconfigured GUIDED_SFM_ARTIFACTS_URL):
    not ready, naming the store, as JSON, without the bucket's name; not a bare 500."""
    for name, value in {"AWS_ACCESS_KEY_ID": "x", "AWS_SECRET_ACCESS_KEY": "y",
                        "AWS_DEFAULT_REGION": "us-east-1"}.items():
        monkeypatch.setenv(name, value)
    settings = make_settings(tmp_path / "data", database_url, artifacts_url="s3://no such bucket/art",
                             s3_endpoint_url="http://127.0.0.1:9")  # port 9: nothing listens
    with TestClient(create_app(settings, lambda _: None, sessions=sessions, readiness=dict)) as client:
        response = client.get("/api/v1/health/ready")
        assert response.status_code == 503 and response.json()["down"] == ["store"], response.text
        assert "artifact store unavailable" in response.json()["detail"]
        assert "no such bucket" not in response.text
