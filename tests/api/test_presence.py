"""Presence: each report says where the caller is and answers everyone seen in the last 30 s."""

from datetime import timedelta

from sqlalchemy import update

from guided_sfm.db.models import Presence, utcnow
from tests.factories import add_member, signup


def report(client, s, headers, **body):
    response = client.post(f"/api/v1/projects/{s.pid}/presence", json=body, headers=headers)
    assert response.status_code == 200, response.text
    return response.json()


def test_who_is_here_and_in_which_edit_set(client, reconstructed, session):
    s = reconstructed
    ben = signup(client, "ben")
    add_member(client, s.owner, s.pid, "ben", "viewer")
    eid = client.post(f"/api/v1/projects/{s.pid}/edits", json={"base_version_id": s.vid},
                      headers=s.owner).json()["id"]
    assert [p["username"] for p in report(client, s, s.owner, edit_set_id=eid)] == ["owner"]
    seen = report(client, s, ben, version_id=s.vid)
    assert [(p["username"], p["edit_set_id"], p["version_id"]) for p in seen] == [
        ("ben", None, s.vid), ("owner", eid, None)]
    moved = report(client, s, s.owner)  # the owner left the edit set
    assert [(p["username"], p["edit_set_id"]) for p in moved] == [("ben", None), ("owner", None)]
    assert session.query(Presence).count() == 2  # one row per member, overwritten
    # ben's last report is 31 s old: he is gone
    session.execute(update(Presence).where(Presence.user_id != None)  # noqa: E711
                    .values(seen_at=utcnow() - timedelta(seconds=31)))
    session.commit()
    assert [p["username"] for p in report(client, s, s.owner)] == ["owner"]


def test_a_foreign_edit_set_is_404_and_a_stranger_sees_nobody(client, reconstructed):
    s = reconstructed
    url = f"/api/v1/projects/{s.pid}/presence"
    response = client.post(url, json={"edit_set_id": 999999}, headers=s.owner)
    assert response.status_code == 404 and "edit set 999999" in response.json()["detail"]
    stranger = signup(client, "stranger")
    assert client.post(f"/api/v1/projects/{s.pid}/presence", json={}, headers=stranger).status_code == 404
    bad = client.post(f"/api/v1/projects/{s.pid}/presence", json={"where": "here"}, headers=s.owner)
    assert bad.status_code == 422
