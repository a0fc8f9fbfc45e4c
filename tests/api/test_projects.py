"""Projects and members."""

import pytest

from guided_sfm.db import queries
from guided_sfm.db.models import Image, Job, Membership, Project, Version
from tests.factories import PASSWORD, add_member, jpeg_bytes, make_project, signup, zip_bytes


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


def test_the_project_list_names_the_role_and_the_owner(client):
    alice, bob = signup(client, "alice"), signup(client, "bob")
    pid = make_project(client, alice)
    add_member(client, alice, pid, "bob", "viewer")
    [listed] = client.get("/api/v1/projects", headers=bob).json()
    assert (listed["id"], listed["role"], listed["owner"]) == (pid, "viewer", "alice")
    assert client.get(f"/api/v1/projects/{pid}", headers=alice).json()["owner"] == "alice"


def test_last_owner_stays(client, session):
    alice = signup(client, "alice")
    pid = make_project(client, alice)
    demote = client.put(f"/api/v1/projects/{pid}/members/alice", json={"role": "editor"}, headers=alice)
    assert demote.status_code == 409 and "last owner" in demote.json()["detail"]
    assert client.delete(f"/api/v1/projects/{pid}/members/alice", headers=alice).status_code == 409
    alice_id = queries.user_by_name(session, "alice").id
    session.expire_all()
    assert session.get(Membership, (pid, alice_id)).role == "owner"  # ids differ on Postgres: look it up
    members = client.get(f"/api/v1/projects/{pid}/members", headers=alice).json()
    assert members == [{"username": "alice", "role": "owner"}]


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


def test_project_and_member_actions_run_without_the_api(session, store):
    """The rules live in actions taking a Session: owner membership, roles, the last owner."""
    from guided_sfm.actions import accounts, members, projects
    from guided_sfm.errors import Conflict, Forbidden, NotFound

    alice, bob = (accounts.sign_up(session, True, name, PASSWORD, str.upper) for name in ("alice", "bob"))
    with pytest.raises(Forbidden, match="OPEN_SIGNUP"):
        accounts.sign_up(session, False, "carol", PASSWORD, str.upper)
    with pytest.raises(Conflict, match="'bob' is taken"):
        accounts.sign_up(session, True, "bob", PASSWORD, str.upper)
    project = projects.create(session, store, alice.id, "hall", "d")
    assert session.get(Membership, (project.id, alice.id)).role == "owner"
    assert members.set_role(session, project, "bob", "editor").role == "editor"
    with pytest.raises(Conflict, match="'alice' is the last owner"):
        members.set_role(session, project, "alice", "viewer")
    members.set_role(session, project, "bob", "owner")
    members.set_role(session, project, "alice", "viewer")  # two owners: one may step down
    with pytest.raises(Conflict, match="'bob' is the last owner"):
        members.remove(session, project, "bob")
    members.remove(session, project, "alice")
    with pytest.raises(NotFound, match="'alice' is not a member"):
        members.remove(session, project, "alice")
    with pytest.raises(NotFound, match="no user named 'nobody'"):
        members.set_role(session, project, "nobody", "viewer")
    assert [(m.user.username, m.role) for m in queries.members(session, project.id)] == [("bob", "owner")]


def test_delete_a_project_with_a_head_removes_versions_and_files(client, reconstructed, session, store):
    s = reconstructed
    version_dir = store.version_dir(session.get(Version, s.vid).path)
    assert version_dir.is_dir()
    assert client.delete(f"/api/v1/projects/{s.pid}", headers=s.owner).status_code == 204
    session.expire_all()
    assert session.get(Project, s.pid) is None and session.get(Version, s.vid) is None
    assert not version_dir.exists() and not store.project_dir(s.pid).exists()


def test_import_keeps_the_upload_only_for_a_queued_job(client, session, store, tmp_path):
    alice = signup(client, "alice")
    pid = make_project(client, alice)
    archive = zip_bytes({"database.db": b"x", "sparse/0/cameras.bin": b"x", "images/a.jpg": jpeg_bytes()})
    queued = client.post(f"/api/v1/projects/{pid}/import", files={"file": ("w.zip", archive)}, headers=alice)
    assert queued.status_code == 202, queued.text
    kept = list(store.uploads_dir(pid).iterdir())
    params = session.get(Job, queued.json()["id"]).params
    assert len(kept) == 1 and store.root / params["upload"] == kept[0]
    again = client.post(f"/api/v1/projects/{pid}/import", files={"file": ("w.zip", archive)}, headers=alice)
    assert again.status_code == 409 and "queued or running" in again.json()["detail"]
    assert list(store.uploads_dir(pid).iterdir()) == kept


def test_a_new_project_never_sees_files_a_crashed_deletion_left(client, session, store):
    """Deletion commits the rows, then removes the files; a crash in between leaves the folder. On
    SQLite the next project may get the same id: it must start empty."""
    owner = signup(client, "alice")
    pid = make_project(client, owner, "old team")
    leftover = store.image_file(pid, "secret.jpg")
    leftover.parent.mkdir(parents=True)
    leftover.write_bytes(jpeg_bytes())
    session.execute(Project.__table__.delete().where(Project.id == pid))  # the crash: rows gone, files not
    session.commit()
    new = make_project(client, owner, "new team")
    assert not store.image_file(new, "secret.jpg").exists()
    assert client.get(f"/api/v1/projects/{new}/images", headers=owner).json() == []
