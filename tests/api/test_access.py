"""The access matrix: no role -> 404, viewer cannot change (403), editor cannot manage members,
a token is needed everywhere but sign-up and token."""

import pytest

from tests.factories import add_member, jpeg_bytes, signup

VIEWER, EDITOR, OWNER = "viewer", "editor", "owner"


def routes(pid: int, vid: int, eid: int, jid: int, iid: int, edit: dict) -> list[tuple]:
    """(method, path, needed role, request kwargs) for every route under a project or a job."""
    p = f"/api/v1/projects/{pid}"
    image = {"files": [("files", ("new.jpg", jpeg_bytes(), "image/jpeg"))]}
    return [
        ("GET", p, VIEWER, {}),
        ("DELETE", p, OWNER, {}),
        ("GET", f"{p}/members", VIEWER, {}),
        ("PUT", f"{p}/members/someone", OWNER, {"json": {"role": "viewer"}}),
        ("DELETE", f"{p}/members/someone", OWNER, {}),
        ("POST", f"{p}/images", EDITOR, image),
        ("GET", f"{p}/images", VIEWER, {}),
        ("GET", f"{p}/images/{iid}/thumbnail", VIEWER, {}),
        ("GET", f"{p}/images/{iid}/file", VIEWER, {}),
        ("DELETE", f"{p}/images/{iid}", EDITOR, {}),
        ("POST", f"{p}/reconstruct", EDITOR, {"json": {}}),
        ("POST", f"{p}/import", EDITOR, {"files": {"file": ("ws.zip", b"PK", "application/zip")}}),
        ("GET", f"{p}/jobs", VIEWER, {}),
        ("GET", f"/api/v1/jobs/{jid}", VIEWER, {}),
        ("POST", f"/api/v1/jobs/{jid}/cancel", EDITOR, {}),
        ("GET", f"{p}/versions", VIEWER, {}),
        ("GET", f"{p}/versions/{vid}/scene", VIEWER, {}),
        ("GET", f"{p}/versions/{vid}/pairs", VIEWER, {}),
        ("POST", f"{p}/versions/{vid}/restore", EDITOR, {}),
        ("GET", f"{p}/versions/{vid}/export", VIEWER, {}),
        ("GET", f"{p}/versions/{vid}/compare?to={vid}", VIEWER, {}),
        ("POST", f"{p}/edits", EDITOR, {"json": edit}),
        ("GET", f"{p}/edits", VIEWER, {}),
        ("GET", f"{p}/edits/{eid}", VIEWER, {}),
        ("PUT", f"{p}/edits/{eid}", EDITOR, {"json": edit, "headers": {"If-Match": "1"}}),
        ("DELETE", f"{p}/edits/{eid}", EDITOR, {}),
        ("GET", f"{p}/edits/{eid}/preview", VIEWER, {}),
        ("POST", f"{p}/edits/{eid}/apply", EDITOR, {"json": {"remap": True}}),
        ("POST", f"{p}/edits/{eid}/rebase", EDITOR, {"headers": {"If-Match": "1"}}),
    ]


@pytest.fixture
def matrix(client, reconstructed, submitted):
    s = reconstructed
    edit = {"base_version_id": s.vid, "cameras": []}
    eid = client.post(f"/api/v1/projects/{s.pid}/edits", json=edit, headers=s.owner).json()["id"]
    # a finished job, so cancel answers 409 to those allowed and nothing is left queued
    jid = client.post(f"/api/v1/projects/{s.pid}/reconstruct", json={}, headers=s.owner).json()["id"]
    client.post(f"/api/v1/jobs/{jid}/cancel", headers=s.owner)
    users = {"outsider": signup(client, "outsider")}
    for role in (VIEWER, EDITOR):
        users[role] = signup(client, role)
        add_member(client, s.owner, s.pid, role, role)
    iid = next(iter(s.image_ids.values()))
    return routes(s.pid, s.vid, eid, jid, iid, edit), users


def call(client, method, path, headers, kwargs):
    kwargs = dict(kwargs)
    headers = {**headers, **kwargs.pop("headers", {})}
    return client.request(method, path, headers=headers, **kwargs)


def test_matrix_covers_every_route(client, matrix):
    listed = {(m, p.split("?")[0]) for m, p, _, _ in matrix[0]}
    templates = set()
    for path, operations in client.app.openapi()["paths"].items():
        for method in operations:
            templates.add((method.upper(), path))
    def shape(path):
        return tuple("{}" if part.isdigit() or part == "someone" else part for part in path.split("/"))
    open_routes = {("POST", "/api/v1/users"), ("POST", "/api/v1/auth/token"), ("GET", "/api/v1/health"),
                   ("GET", "/api/v1/projects"), ("POST", "/api/v1/projects")}
    expected = {(m, tuple("{}" if "{" in part else part for part in p.split("/")))
                for m, p in templates - open_routes}
    assert expected == {(m, shape(p)) for m, p in listed}


def test_no_token_is_401_everywhere(client, matrix):
    for method, path, _, kwargs in matrix[0]:
        response = call(client, method, path, {}, kwargs)
        assert response.status_code == 401, (method, path, response.text)


def test_no_role_is_404_everywhere(client, matrix):
    for method, path, _, kwargs in matrix[0]:
        response = call(client, method, path, matrix[1]["outsider"], kwargs)
        assert response.status_code == 404, (method, path, response.text)
        assert "not found" in response.json()["detail"]


def test_viewer_reads_but_cannot_change(client, matrix):
    for method, path, needed, kwargs in matrix[0]:
        response = call(client, method, path, matrix[1][VIEWER], kwargs)
        if needed == VIEWER:
            assert response.status_code == 200, (method, path, response.text)
        else:
            assert response.status_code == 403, (method, path, response.text)
            assert "viewer" in response.json()["detail"]


def test_editor_cannot_manage_members_or_delete(client, matrix):
    for method, path, needed, kwargs in matrix[0]:
        response = call(client, method, path, matrix[1][EDITOR], kwargs)
        if needed == OWNER:
            assert response.status_code == 403, (method, path, response.text)
        else:
            assert response.status_code != 403, (method, path, response.text)
