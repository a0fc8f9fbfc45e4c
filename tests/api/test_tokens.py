"""Personal access tokens (scope, projects, expiry, revocation) and password change."""

from datetime import timedelta

import pytest

from guided_sfm.actions import tokens
from guided_sfm.db.models import AccessToken, utcnow
from tests.factories import PASSWORD, add_member, make_project, signup


def mint(client, headers, **body):
    response = client.post("/api/v1/tokens", json={"name": "ci", "scope": "write", **body}, headers=headers)
    assert response.status_code == 201, response.text
    return response.json()


def bearer(secret):
    return {"Authorization": f"Bearer {secret}"}


def test_token_is_shown_once_and_stored_hashed(client, session):
    ann = signup(client, "ann")
    made = mint(client, ann, scope="read", expires_days=30)
    assert made["token"].startswith(tokens.PREFIX) and made["scope"] == "read"
    assert made["expires_at"] is not None
    listed = client.get("/api/v1/tokens", headers=ann).json()
    assert [t["id"] for t in listed] == [made["id"]] and "token" not in listed[0]
    row = session.get(AccessToken, made["id"])
    assert made["token"] not in row.digest and row.digest == tokens.digest(made["token"])


def test_token_works_until_revoked(client):
    ann = signup(client, "ann")
    made = mint(client, ann)
    pid = make_project(client, bearer(made["token"]), "by token")
    assert client.get(f"/api/v1/projects/{pid}", headers=bearer(made["token"])).status_code == 200
    assert client.delete(f"/api/v1/tokens/{made['id']}", headers=ann).status_code == 204
    response = client.get(f"/api/v1/projects/{pid}", headers=bearer(made["token"]))
    assert response.status_code == 401 and "revoked" in response.json()["detail"]


def test_read_token_cannot_change_anything(client):
    ann = signup(client, "ann")
    pid = make_project(client, ann)
    read = bearer(mint(client, ann, scope="read")["token"])
    assert client.get(f"/api/v1/projects/{pid}/images", headers=read).status_code == 200
    for method, path, body in (("POST", "/api/v1/projects", {"name": "x"}),
                               ("PUT", f"/api/v1/projects/{pid}/members/ann", {"role": "owner"}),
                               ("DELETE", f"/api/v1/projects/{pid}", None)):
        response = client.request(method, path, json=body, headers=read)
        assert response.status_code == 403, (method, path, response.text)
        assert "read-only" in response.json()["detail"]
    assert client.get(f"/api/v1/projects/{pid}", headers=ann).status_code == 200


def test_project_limited_token_sees_only_its_projects(client):
    ann = signup(client, "ann")
    mine, other = make_project(client, ann, "mine"), make_project(client, ann, "other")
    limited = bearer(mint(client, ann, projects=[mine])["token"])
    assert [p["id"] for p in client.get("/api/v1/projects", headers=limited).json()] == [mine]
    assert client.get(f"/api/v1/projects/{mine}/members", headers=limited).status_code == 200
    response = client.get(f"/api/v1/projects/{other}/members", headers=limited)
    assert response.status_code == 404 and "not found" in response.json()["detail"]
    assert client.post("/api/v1/projects", json={"name": "x"}, headers=limited).status_code == 403


def test_token_for_a_project_without_a_role_is_refused(client):
    ann, bob = signup(client, "ann"), signup(client, "bob")
    bobs = make_project(client, bob, "bob's")
    response = client.post("/api/v1/tokens", json={"name": "x", "scope": "read", "projects": [bobs]},
                           headers=ann)
    assert response.status_code == 422 and f"project {bobs}" in response.json()["detail"]
    assert client.get("/api/v1/tokens", headers=ann).json() == []


def test_token_limited_to_a_role_it_has(client):
    """The token carries the person's role, never more: a viewer's write token still cannot edit."""
    ann, bob = signup(client, "ann"), signup(client, "bob")
    pid = make_project(client, ann)
    add_member(client, ann, pid, "bob", "viewer")
    write = bearer(mint(client, bob, projects=[pid])["token"])
    response = client.put(f"/api/v1/projects/{pid}/members/bob", json={"role": "owner"}, headers=write)
    assert response.status_code == 403 and "viewer" in response.json()["detail"]


def test_expired_token_is_401(client, session):
    ann = signup(client, "ann")
    made = mint(client, ann, expires_days=1)
    row = session.get(AccessToken, made["id"])
    row.expires_at = utcnow() - timedelta(seconds=1)
    session.commit()
    response = client.get("/api/v1/projects", headers=bearer(made["token"]))
    assert response.status_code == 401 and "expired" in response.json()["detail"]


def test_someone_elses_token_cannot_be_revoked_or_listed(client):
    ann, bob = signup(client, "ann"), signup(client, "bob")
    made = mint(client, ann)
    assert client.get("/api/v1/tokens", headers=bob).json() == []
    assert client.delete(f"/api/v1/tokens/{made['id']}", headers=bob).status_code == 404
    assert client.get("/api/v1/projects", headers=bearer(made["token"])).status_code == 200


def test_a_token_cannot_mint_tokens_or_change_the_password(client):
    ann = signup(client, "ann")
    token = bearer(mint(client, ann)["token"])
    again = client.post("/api/v1/tokens", json={"name": "y", "scope": "write"}, headers=token)
    assert again.status_code == 403
    body = {"old_password": PASSWORD, "new_password": "another good one"}
    assert client.post("/api/v1/users/me/password", json=body, headers=token).status_code == 403


def test_password_change_ends_sessions_but_not_tokens(client):
    ann = signup(client, "ann")
    token = bearer(mint(client, ann)["token"])
    wrong = {"old_password": "not it at all", "new_password": "another good one"}
    assert client.post("/api/v1/users/me/password", json=wrong, headers=ann).status_code == 403
    assert client.get("/api/v1/projects", headers=ann).status_code == 200
    body = {"old_password": PASSWORD, "new_password": "another good one"}
    assert client.post("/api/v1/users/me/password", json=body, headers=ann).status_code == 204
    response = client.get("/api/v1/projects", headers=ann)
    assert response.status_code == 401 and "password changed" in response.json()["detail"]
    assert client.get("/api/v1/projects", headers=token).status_code == 200
    old = client.post("/api/v1/auth/token", data={"username": "ann", "password": PASSWORD})
    assert old.status_code == 401
    new = client.post("/api/v1/auth/token", data={"username": "ann", "password": "another good one"})
    fresh = bearer(new.json()["access_token"])
    assert client.get("/api/v1/projects", headers=fresh).status_code == 200


def test_of_two_password_changes_at_once_one_wins(client, session):
    """The hash is checked outside any transaction; the write only lands on the hash it checked."""
    from sqlalchemy import update

    from guided_sfm.api import security
    from guided_sfm.db.models import User
    from guided_sfm.errors import Conflict

    signup(client, "ann")
    user = session.query(User).filter_by(username="ann").one()

    def verify_while_another_changes_it(old, stored):
        session.execute(update(User).where(User.id == user.id).values(password_hash="changed by the other"))
        session.commit()
        return security.verify_password(old, stored)

    with pytest.raises(Conflict):
        tokens.change_password(session, user, PASSWORD, "another good one", verify_while_another_changes_it,
                               security.hash_password)
    session.expire_all()
    assert session.get(User, user.id).password_hash == "changed by the other"
