"""Review of edit sets: submit -> approve / request changes by another editor or owner; the owner's
require_approval gates apply (409 until approved); a new revision puts an approval back to draft."""

import pytest

from guided_sfm.actions import runner
from guided_sfm.db.models import EditSetRow, Job, Review
from tests.factories import add_member, signup


def api(s, suffix=""):
    return f"/api/v1/projects/{s.pid}{suffix}"


@pytest.fixture
def team(client, reconstructed):
    s = reconstructed
    people = {"owner": s.owner}
    for name, role in (("ana", "editor"), ("ben", "editor"), ("vic", "viewer")):
        people[name] = signup(client, name)
        add_member(client, s.owner, s.pid, name, role)
    pair = client.get(api(s, f"/versions/{s.vid}/pairs"), headers=s.owner).json()[0]
    body = {"base_version_id": s.vid, "delete_pairs": [[pair["image_id1"], pair["image_id2"]]]}
    eid = client.post(api(s, "/edits"), json=body, headers=people["ana"]).json()["id"]
    return s, people, eid


def review(client, s, headers, eid, verdict="approve", comment=""):
    return client.post(api(s, f"/edits/{eid}/reviews"), json={"verdict": verdict, "comment": comment},
                       headers=headers)


def state(client, s, eid):
    return client.get(api(s, f"/edits/{eid}"), headers=s.owner).json()


def test_submit_approve_then_apply_under_require_approval(client, team, session, sessions, settings):
    s, people, eid = team
    assert client.patch(api(s), json={"require_approval": True}, headers=s.owner).json()["require_approval"]
    gated = client.post(api(s, f"/edits/{eid}/apply"), json={"remap": False}, headers=people["ana"])
    assert gated.status_code == 409
    assert "approv" in gated.json()["detail"] and "draft" in gated.json()["detail"]
    assert review(client, s, people["ben"], eid).status_code == 409  # not submitted yet
    submitted = client.post(api(s, f"/edits/{eid}/submit"), headers=people["ana"])
    assert submitted.status_code == 200 and submitted.json()["review_state"] == "in_review"
    assert client.post(api(s, f"/edits/{eid}/submit"), headers=people["ana"]).status_code == 409
    still = client.post(api(s, f"/edits/{eid}/apply"), json={"remap": False}, headers=people["ana"])
    assert still.status_code == 409 and "in_review" in still.json()["detail"]
    asked = client.get("/api/v1/notifications", headers=people["ben"]).json()
    assert [(n["kind"], n["target"]) for n in asked] == [
        ("review_requested", {"kind": "edit_set", "id": eid})]
    assert client.get("/api/v1/notifications", headers=people["vic"]).json() == []  # viewers review nothing
    assert client.get("/api/v1/notifications", headers=people["ana"]).json() == []  # nor asks herself

    approved = review(client, s, people["ben"], eid, comment="checked the wall")
    assert approved.status_code == 201, approved.text
    assert approved.json()["review_state"] == "approved" and approved.json()["reviewer"] == "ben"
    data = state(client, s, eid)
    assert data["review_state"] == "approved" and data["author"] == "ana"
    assert [(r["reviewer"], r["verdict"], r["comment"], r["revision"]) for r in data["reviews"]] == [
        ("ben", "approve", "checked the wall", 1)]
    told = client.get("/api/v1/notifications", headers=people["ana"]).json()
    assert [n["kind"] for n in told] == ["reviewed"] and "ben approved" in told[0]["text"]
    applied = client.post(api(s, f"/edits/{eid}/apply"), json={"remap": False, "message": "fix the wall"},
                          headers=people["ana"])
    assert applied.status_code == 202, applied.text
    assert runner.run_job(sessions, settings, applied.json()["id"]) == "succeeded"
    version = session.get(Job, applied.json()["id"]).version_id
    versions = client.get(api(s, "/versions"), headers=s.owner).json()
    assert next(v for v in versions if v["id"] == version)["message"].startswith("fix the wall (edit set")
    assert [n["kind"] for n in client.get("/api/v1/notifications", headers=people["ana"]).json()] == [
        "job_finished", "reviewed"]


def test_self_review_and_a_viewers_review_are_403(client, team, session):
    s, people, eid = team
    client.post(api(s, f"/edits/{eid}/submit"), headers=people["ana"])
    mine = review(client, s, people["ana"], eid)
    assert mine.status_code == 403 and "you wrote" in mine.json()["detail"]
    viewer = review(client, s, people["vic"], eid)
    assert viewer.status_code == 403 and "viewer" in viewer.json()["detail"]
    assert session.query(Review).count() == 0
    # whoever saved the current revision wrote it too
    client.put(api(s, f"/edits/{eid}"), json={"base_version_id": s.vid},
               headers={**people["ben"], "If-Match": "1"})
    assert review(client, s, people["ben"], eid).status_code == 403
    assert review(client, s, s.owner, eid).status_code == 201


def test_a_new_revision_puts_an_approval_back_to_draft(client, team):
    s, people, eid = team
    client.patch(api(s), json={"require_approval": True}, headers=s.owner)
    client.post(api(s, f"/edits/{eid}/submit"), headers=people["ana"])
    assert review(client, s, people["ben"], eid).status_code == 201
    kept = {"base_version_id": s.vid, "delete_pairs": state(client, s, eid)["delete_pairs"], "flags": []}
    saved = client.put(api(s, f"/edits/{eid}"), json=kept, headers={**people["ana"], "If-Match": "1"})
    assert saved.status_code == 200 and saved.json()["review_state"] == "draft"
    gated = client.post(api(s, f"/edits/{eid}/apply"), json={"remap": False}, headers=people["ana"])
    assert gated.status_code == 409
    # resubmitted and approved at revision 2, it may run
    client.post(api(s, f"/edits/{eid}/submit"), headers=people["ana"])
    assert review(client, s, people["ben"], eid).json()["revision"] == 2
    applied = client.post(api(s, f"/edits/{eid}/apply"), json={"remap": False}, headers=people["ana"])
    assert applied.status_code == 202


def test_requested_changes_go_back_to_the_author(client, team, session):
    s, people, eid = team
    client.post(api(s, f"/edits/{eid}/submit"), headers=people["ana"])
    asked = review(client, s, s.owner, eid, "request_changes", "camera 3 is still off")
    assert asked.status_code == 201 and asked.json()["review_state"] == "changes_requested"
    assert review(client, s, people["ben"], eid).status_code == 409  # no longer in review
    again = client.post(api(s, f"/edits/{eid}/submit"), headers=people["ana"])
    assert again.json()["review_state"] == "in_review"
    log = client.get(api(s, "/activity"), params={"action": "review"}, headers=s.owner).json()["items"]
    assert [(e["user"], e["detail"]["verdict"]) for e in log] == [("owner", "request_changes")]
    assert session.get(EditSetRow, eid).review_state == "in_review"


def test_without_require_approval_a_draft_applies(client, team):
    s, people, eid = team
    response = client.post(api(s, f"/edits/{eid}/apply"), json={"remap": False}, headers=people["ana"])
    assert response.status_code == 202, response.text


def test_only_owners_change_settings(client, team, session):
    s, people, _ = team
    for name in ("ana", "vic"):
        response = client.patch(api(s), json={"require_approval": True}, headers=people[name])
        assert response.status_code == 403
    assert client.get(api(s), headers=s.owner).json()["require_approval"] is False
    bad = client.patch(api(s), json={"require_approval": "maybe"}, headers=s.owner)
    assert bad.status_code == 422
