"""Sign-up and tokens; every other route needs a bearer token."""

import pytest

from tests.conftest import make_settings
from tests.factories import PASSWORD, signup


def test_sign_up_and_token(client):
    response = client.post("/api/v1/users", json={"username": "ann", "password": PASSWORD})
    assert response.status_code == 201
    assert set(response.json()) == {"id", "username"}
    token = client.post("/api/v1/auth/token", data={"username": "ann", "password": PASSWORD})
    assert token.status_code == 200
    assert token.json()["token_type"] == "bearer"


def test_taken_username_is_409(client):
    signup(client, "ann")
    response = client.post("/api/v1/users", json={"username": "ann", "password": PASSWORD})
    assert response.status_code == 409
    assert "taken" in response.json()["detail"]


BAD_SIGN_UPS = [{"username": "x", "password": "short"}, {"username": "", "password": PASSWORD},
                {"username": "a b/c", "password": PASSWORD}, {"username": "x"}]


@pytest.mark.parametrize("body", BAD_SIGN_UPS)
def test_bad_sign_up_is_422_with_detail(client, body):
    response = client.post("/api/v1/users", json=body)
    assert response.status_code == 422
    assert isinstance(response.json()["detail"], str)


def test_wrong_password_is_401(client):
    signup(client, "ann")
    for username, password in (("ann", "wrong password"), ("nobody", PASSWORD)):
        response = client.post("/api/v1/auth/token", data={"username": username, "password": password})
        assert response.status_code == 401
        assert response.json()["detail"] == "wrong username or password"


def test_closed_sign_up_is_403(tmp_path, database_url, sessions):
    from fastapi.testclient import TestClient

    from guided_sfm.api.app import create_app

    settings = make_settings(tmp_path, database_url, open_signup=False)
    with TestClient(create_app(settings, lambda job_id: None, sessions=sessions)) as client:
        response = client.post("/api/v1/users", json={"username": "ann", "password": PASSWORD})
    assert response.status_code == 403
    assert "closed" in response.json()["detail"]


@pytest.mark.parametrize("header", [None, "Bearer not-a-token", "Basic abc"])
def test_routes_need_a_valid_token(client, header):
    headers = {"Authorization": header} if header else {}
    routes = [("GET", "/api/v1/projects"), ("POST", "/api/v1/projects"), ("GET", "/api/v1/jobs/1")]
    for method, path in routes:
        response = client.request(method, path, headers=headers, json={"name": "x"})
        assert response.status_code == 401, (method, path)
        assert response.json()["detail"]


def test_token_of_deleted_user_is_401(client, session):
    from guided_sfm.db.models import User

    headers = signup(client, "gone")
    session.delete(session.query(User).filter_by(username="gone").one())
    session.commit()
    assert client.get("/api/v1/projects", headers=headers).status_code == 401
