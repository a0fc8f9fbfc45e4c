"""The activity log: every change with who made it (and through which access token), newest first,
paged by id without duplicates, filtered by user and action; refused requests log nothing."""

from guided_sfm.actions import runner
from guided_sfm.db.models import ACTIVITY_ACTIONS
from tests.factories import add_member, jpeg_bytes, make_project, signup, workspace_zip


def api(s, suffix=""):
    return f"/api/v1/projects/{s.pid}{suffix}"


def entries(client, s, headers=None, **params):
    response = client.get(api(s, "/activity"), params={"limit": 200, **params}, headers=headers or s.owner)
    assert response.status_code == 200, response.text
    return response.json()["items"]


def ok(response, status=200):
    assert response.status_code == status, response.text
    return response.json() if response.content else None


def nonempty(client, s) -> dict:
    """An edit set that deletes one pair (an empty one has nothing to apply: 422)."""
    pair = client.get(api(s, f"/versions/{s.vid}/pairs"), headers=s.owner).json()[0]
    return {"base_version_id": s.vid, "delete_pairs": [[pair["image_id1"], pair["image_id2"]]]}


def test_every_change_is_logged_with_its_user(client, reconstructed, sessions, settings, tiny_reconstruction,
                                              tiny_images):
    s = reconstructed
    ben = signup(client, "ben")
    add_member(client, s.owner, s.pid, "ben", "editor")
    ok(client.post(api(s, "/images"), files={"files": ("new.jpg", jpeg_bytes(), "image/jpeg")},
                   headers=s.owner), 201)
    job = ok(client.post(api(s, "/reconstruct"), json={}, headers=s.owner), 202)
    ok(client.post(f"/api/v1/jobs/{job['id']}/cancel", headers=s.owner))
    ok(client.patch(api(s), json={"require_approval": True}, headers=s.owner))
    eid = ok(client.post(api(s, "/edits"), json=nonempty(client, s), headers=ben), 201)["id"]
    ok(client.put(api(s, f"/edits/{eid}"), json={**nonempty(client, s), "flags": []},
                  headers={**ben, "If-Match": "1"}))
    ok(client.post(api(s, f"/edits/{eid}/submit"), headers=ben))
    ok(client.post(api(s, f"/edits/{eid}/reviews"), json={"verdict": "approve"}, headers=s.owner), 201)
    applied = ok(client.post(api(s, f"/edits/{eid}/apply"), json={"remap": False}, headers=ben), 202)
    assert runner.run_job(sessions, settings, applied["id"]) == "succeeded"
    ok(client.post(api(s, f"/versions/{s.vid}/restore"), headers=s.owner), 201)
    ok(client.post(api(s, f"/versions/{s.vid}/publish"), headers=s.owner))
    other = ok(client.post(api(s, "/edits"), json={"base_version_id": s.vid}, headers=s.owner), 201)["id"]
    assert client.delete(api(s, f"/edits/{other}"), headers=s.owner).status_code == 204
    empty = make_project(client, s.owner, "empty")
    zipped = workspace_zip(tiny_reconstruction, tiny_images / "images")
    ok(client.post(f"/api/v1/projects/{empty}/import", files={"file": ("ws.zip", zipped, "application/zip")},
                   headers=s.owner), 202)

    log = entries(client, s)
    by_action = {}
    for entry in log:
        by_action.setdefault(entry["action"], []).append(entry)
    expected = set(ACTIVITY_ACTIONS) - {"import", "comment"}  # import went to the other project
    assert expected <= set(by_action), sorted(expected - set(by_action))
    assert [e["id"] for e in log] == sorted((e["id"] for e in log), reverse=True)  # newest first
    users = {(e["action"], e["user"]) for e in log}
    assert {("upload", "owner"), ("reconstruct", "owner"), ("settings", "owner"), ("edit_save", "ben"),
            ("submit", "ben"), ("review", "owner"), ("apply", "ben"), ("restore", "owner"),
            ("publish", "owner"), ("member", "owner"), ("edit_delete", "owner")} <= users
    saves = [e["detail"]["revision"] for e in by_action["edit_save"] if e["target"]["id"] == eid]
    assert sorted(saves) == [1, 2]
    assert by_action["review"][0]["detail"]["verdict"] == "approve"
    assert by_action["settings"][0]["detail"] == {"require_approval": True}
    ends = {e["detail"]["state"]: e for e in by_action["job_end"]}
    assert set(ends) == {"cancelled", "succeeded"}
    assert ends["succeeded"]["user"] == "ben" and ends["succeeded"]["target"]["kind"] == "version"
    assert ends["succeeded"]["target"]["id"] == ends["succeeded"]["detail"]["version_id"] is not None
    assert by_action["member"][0]["detail"] == {"username": "ben", "role": "editor"}
    assert all(e["token"] is None for e in log)
    imported = client.get(f"/api/v1/projects/{empty}/activity", headers=s.owner).json()["items"]
    assert [(e["action"], e["user"]) for e in imported] == [("import", "owner")]


def test_a_change_through_an_access_token_names_the_token(client, reconstructed, sessions, settings):
    s = reconstructed
    body = {"name": "nightly-ci", "scope": "write"}
    made = ok(client.post("/api/v1/tokens", json=body, headers=s.owner), 201)
    bot = {"Authorization": f"Bearer {made['token']}"}
    eid = ok(client.post(api(s, "/edits"), json=nonempty(client, s), headers=bot), 201)["id"]
    job = ok(client.post(api(s, f"/edits/{eid}/apply"), json={"remap": False}, headers=bot), 202)
    assert runner.run_job(sessions, settings, job["id"]) == "succeeded"
    ok(client.patch(api(s), json={"description": "by hand"}, headers=s.owner))
    log = {e["action"]: e for e in entries(client, s)}
    for action in ("edit_save", "apply", "job_end"):
        assert log[action]["token"] == "nightly-ci" and log[action]["user"] == "owner", log[action]
    assert log["settings"]["token"] is None


def test_pages_are_disjoint_and_complete_while_entries_arrive(client, reconstructed):
    s = reconstructed
    for n in range(23):
        ok(client.patch(api(s), json={"description": f"d{n}"}, headers=s.owner))
    seen, before, pages = [], None, 0
    while True:
        params = {"limit": 5, **({"before": before} if before else {})}
        page = ok(client.get(api(s, "/activity"), params=params, headers=s.owner))
        seen += [e["id"] for e in page["items"]]
        pages += 1
        ok(client.patch(api(s), json={"description": f"new{pages}"}, headers=s.owner))  # newer than page 1
        before = page["next_before"]
        if before is None:
            break
        assert before == page["items"][-1]["id"]
    assert pages == 5 and len(seen) == 23 and len(set(seen)) == 23
    assert seen == sorted(seen, reverse=True)


def test_filters_by_user_and_action(client, reconstructed):
    s = reconstructed
    ben = signup(client, "ben")
    add_member(client, s.owner, s.pid, "ben", "editor")
    ok(client.post(api(s, "/edits"), json={"base_version_id": s.vid}, headers=ben), 201)
    ok(client.post(api(s, "/edits"), json={"base_version_id": s.vid}, headers=s.owner), 201)
    assert [(e["action"], e["user"]) for e in entries(client, s, user="ben")] == [("edit_save", "ben")]
    assert {e["user"] for e in entries(client, s, action="edit_save")} == {"ben", "owner"}
    assert entries(client, s, action="member") == entries(client, s, user="owner", action="member")
    bad = client.get(api(s, "/activity"), params={"action": "dance"}, headers=s.owner)
    assert bad.status_code == 422 and "dance" in bad.json()["detail"]


def test_a_refused_change_logs_nothing(client, reconstructed):
    s = reconstructed
    eid = ok(client.post(api(s, "/edits"), json={"base_version_id": s.vid}, headers=s.owner), 201)["id"]
    before = entries(client, s)
    stale = client.put(api(s, f"/edits/{eid}"), json={"base_version_id": s.vid},
                       headers={**s.owner, "If-Match": "7"})
    assert stale.status_code == 409
    assert client.post(api(s, f"/versions/{s.vid}/publish"), headers=signup(client, "x")).status_code == 404
    assert entries(client, s) == before


def test_a_job_the_sweeper_fails_is_logged_and_its_author_told(client, reconstructed, session, sessions,
                                                                 settings):
    from datetime import timedelta

    from guided_sfm.db.models import Job, utcnow
    from worker.sweeper import sweep

    s = reconstructed
    job_id = ok(client.post(api(s, "/reconstruct"), json={}, headers=s.owner), 202)["id"]
    job = session.get(Job, job_id)
    stale = utcnow() - timedelta(seconds=settings.stale_seconds + 60)
    job.state, job.attempts, job.heartbeat_at, job.started_at = "running", settings.max_attempts, stale, stale
    session.commit()
    assert sweep(sessions, settings, lambda _job_id: None)["failed"] == [job_id]
    ends = entries(client, s, action="job_end")
    assert [(e["user"], e["detail"]["state"], e["detail"]["job_id"]) for e in ends] == [
        ("owner", "failed", job_id)]
    told = client.get("/api/v1/notifications", headers=s.owner).json()
    assert [(n["kind"], n["target"]["id"]) for n in told] == [("job_finished", job_id)]
