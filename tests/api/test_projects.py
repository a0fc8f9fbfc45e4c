"""Projects and members."""

from guided_sfm.db.models import Image, Membership, Project
from tests.factories import add_member, jpeg_bytes, make_project, signup


def test_create_list_get(client):
    alice, bob = signup(client, "alice"), signup(client, "bob")
    created = client.post("/api/v1/projects", json={"name": "hall", "description": "d"}, headers=alice)
    assert created.status_code == 201
    project = created.json()
    assert project["head_version_id"] is None and project["role"] == "owner"
    assert [p["id"] for p in client.get("/api/v1/projects", headers=alice).json()] == [project["id"]]
    assert client.get("/api/v1/projects", headers=bob).json() == []
    assert client.get(f"/api/v1/projects/{project['id']}", headers=bob).status_code == 404
    assert client.post("/api/v1/projects", json={"name": ""}, headers=alice).status_code == 422


def test_members(client):
    alice, bob = signup(client, "alice"), signup(client, "bob")
    pid = make_project(client, alice)
    add_member(client, alice, pid, "bob", "viewer")
    members = client.get(f"/api/v1/projects/{pid}/members", headers=bob).json()
    assert members == [{"username": "alice", "role": "owner"}, {"username": "bob", "role": "viewer"}]
    assert client.get(f"/api/v1/projects/{pid}", headers=bob).json()["role"] == "viewer"
    missing = client.put(f"/api/v1/projects/{pid}/members/nobody", json={"role": "viewer"}, headers=alice)
    assert missing.status_code == 404 and "nobody" in missing.json()["detail"]
    bad_role = client.put(f"/api/v1/projects/{pid}/members/bob", json={"role": "admin"}, headers=alice)
    assert bad_role.status_code == 422
    assert client.delete(f"/api/v1/projects/{pid}/members/bob", headers=alice).status_code == 204
    assert client.get(f"/api/v1/projects/{pid}", headers=bob).status_code == 404


def test_last_owner_stays(client, session):
    alice = signup(client, "alice")
    pid = make_project(client, alice)
    demote = client.put(f"/api/v1/projects/{pid}/members/alice", json={"role": "editor"}, headers=alice)
    assert demote.status_code == 409 and "last owner" in demote.json()["detail"]
    assert client.delete(f"/api/v1/projects/{pid}/members/alice", headers=alice).status_code == 409
    assert session.get(Membership, (pid, 1)) is None or session.get(Membership, (pid, 1)).role == "owner"


def test_delete_project_removes_rows_and_files(client, session, settings):
    alice = signup(client, "alice")
    pid = make_project(client, alice)
    files = [("files", ("a.jpg", jpeg_bytes(), "image/jpeg"))]
    assert client.post(f"/api/v1/projects/{pid}/images", files=files, headers=alice).status_code == 201
    job = client.post(f"/api/v1/projects/{pid}/reconstruct", json={}, headers=alice).json()
    busy = client.delete(f"/api/v1/projects/{pid}", headers=alice)
    assert busy.status_code == 409
    client.post(f"/api/v1/jobs/{job['id']}/cancel", headers=alice)
    assert client.delete(f"/api/v1/projects/{pid}", headers=alice).status_code == 204
    session.expire_all()
    assert session.get(Project, pid) is None and session.query(Image).filter_by(project_id=pid).count() == 0
    assert not (settings.artifacts_dir / "projects" / str(pid)).exists()
