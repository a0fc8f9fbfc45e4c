"""Health as design.md pins it: liveness answers 503 when the database does not; readiness names
what is down (the database, the broker, the workers)."""

from guided_sfm.api.app import create_app
from guided_sfm.db.session import make_engine, make_sessionmaker
from tests.conftest import TestClient

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
