"""The access matrix: no role -> 404, viewer cannot change (403), editor cannot manage members,
a token is needed everywhere but sign-up and token."""

import pytest

from tests.factories import add_member, jpeg_bytes, signup

VIEWER, EDITOR, OWNER = "viewer", "editor", "owner"
HOOK = {"url": "https://example.org/", "events": ["job_finished"]}


def routes(pid: int, vid: int, eid: int, jid: int, iid: int, edit: dict, cid: int = 0) -> list[tuple]:
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
        ("GET", f"{p}/versions/{vid}/suspects", VIEWER, {}),
        ("POST", f"{p}/versions/{vid}/restore", EDITOR, {}),
        ("GET", f"{p}/versions/{vid}/export", VIEWER, {}),
        ("GET", f"{p}/versions/{vid}/compare?to={vid}", VIEWER, {}),
        ("POST", f"{p}/edits", EDITOR, {"json": edit}),
        ("GET", f"{p}/edits", VIEWER, {}),
        ("GET", f"{p}/edits/{eid}", VIEWER, {}),
        ("PUT", f"{p}/edits/{eid}", EDITOR, {"json": edit, "headers": {"If-Match": "1"}}),
        ("GET", f"{p}/edits/{eid}/preview", VIEWER, {}),
        ("POST", f"{p}/edits/{eid}/apply", EDITOR, {"json": {"remap": True}}),
        ("POST", f"{p}/webhooks", OWNER, {"json": HOOK}),
        ("GET", f"{p}/webhooks", OWNER, {}),
        ("DELETE", f"{p}/webhooks/1", OWNER, {}),
        ("GET", f"{p}/webhooks/1/deliveries", OWNER, {}),
        ("POST", f"{p}/edits/{eid}/rebase", EDITOR, {"headers": {"If-Match": "1"}}),
    ] + team_routes(p, vid, eid, iid, cid) + [
        ("DELETE", f"{p}/edits/{eid}", EDITOR, {}),  # last: the routes above need the edit set
    ]


def team_routes(p: str, vid: int, eid: int, iid: int, cid: int) -> list[tuple]:
    """The team review routes (design.md v1.1): viewers read the log, comment and report presence;
    editors submit, review, publish and resolve others' comments; owners change settings and delete
    others' comments (`cid` is the owner's)."""
    comment = {"target": {"kind": "image", "id": iid}, "body": "@owner is this right?"}
    return [
        ("POST", f"{p}/comments", VIEWER, {"json": comment}),
        ("GET", f"{p}/comments", VIEWER, {}),
        ("PATCH", f"{p}/comments/{cid}", EDITOR, {"json": {"resolved": True}}),
        ("DELETE", f"{p}/comments/{cid}", OWNER, {}),
        ("POST", f"{p}/presence", VIEWER, {"json": {"version_id": vid}}),
        ("PATCH", p, OWNER, {"json": {"description": "changed"}}),
        ("GET", f"{p}/activity", VIEWER, {}),
        ("POST", f"{p}/edits/{eid}/submit", EDITOR, {}),
        ("POST", f"{p}/edits/{eid}/reviews", EDITOR, {"json": {"verdict": "approve"}}),
        ("POST", f"{p}/versions/{vid}/publish", EDITOR, {}),
    ]


def editor_status(method: str, path: str) -> int:
    """What an editor gets, in the matrix's order: success, or the 409 the state explains (the
    project is not empty for import, the job ended, the editor's own reconstruct is queued, the
    image a version uses), or the 422 of applying the matrix's empty edit set, or the 403 of
    reviewing the edit set the editor saved earlier in the matrix (nobody reviews their own)."""
    if path.endswith("/apply"):
        return 422
    if path.endswith("/reviews"):
        return 403
    if path.endswith(("/import", "/cancel", "/restore")) or (method == "DELETE" and "/images/" in path):
        return 409  # ... and the image is used by the version
    if method == "POST":
        return {"/reconstruct": 202, "/rebase": 200, "/presence": 200, "/submit": 200,
                "/publish": 200}.get(path[path.rindex("/"):], 201)
    return {"GET": 200, "PUT": 200, "PATCH": 200, "DELETE": 204}[method]


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
    cid = client.post(f"/api/v1/projects/{s.pid}/comments", headers=s.owner,
                      json={"target": {"kind": "project"}, "body": "the owner's"}).json()["id"]
    return routes(s.pid, s.vid, eid, jid, iid, edit, cid), users


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
                   ("GET", "/api/v1/health/ready"),
                   ("GET", "/api/v1/projects"), ("POST", "/api/v1/projects"),
                   # the caller's own account (tests/api/test_tokens.py)
                   ("POST", "/api/v1/tokens"), ("GET", "/api/v1/tokens"),
                   ("DELETE", "/api/v1/tokens/{token_id}"), ("POST", "/api/v1/users/me/password"),
                   # the caller's own notifications (tests/api/test_comments.py)
                   ("GET", "/api/v1/notifications"), ("POST", "/api/v1/notifications/read")}
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
            assert response.status_code in (200, 201), (method, path, response.text)
        else:
            assert response.status_code == 403, (method, path, response.text)
            assert "viewer" in response.json()["detail"]


def test_editor_cannot_manage_members_or_delete(client, matrix):
    for method, path, needed, kwargs in matrix[0]:
        response = call(client, method, path, matrix[1][EDITOR], kwargs)
        expected = 403 if needed == OWNER else editor_status(method, path)
        assert response.status_code == expected, (method, path, response.text)
        if expected in (403, 409, 422):
            assert response.json()["detail"], (method, path)

