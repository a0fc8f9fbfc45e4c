"""Comments: every target kind, replies, @mentions -> notifications -> read, plain-text bodies,
resolve/reopen, and who may edit, resolve and delete (nothing stored on a refusal)."""

import pytest

from guided_sfm.db.models import Comment, Notification
from tests.factories import add_member, signup


def api(s, suffix=""):
    return f"/api/v1/projects/{s.pid}/comments{suffix}"


def post(client, s, headers, target, body="looks wrong", status=201, **extra):
    response = client.post(api(s), json={"target": target, "body": body, **extra}, headers=headers)
    assert response.status_code == status, response.text
    return response.json()


@pytest.fixture
def team(client, reconstructed):
    s = reconstructed
    people = {"owner": s.owner}
    for name, role in (("ana", "editor"), ("ben", "editor"), ("vic", "viewer")):
        people[name] = signup(client, name)
        add_member(client, s.owner, s.pid, name, role)
    people["carl"] = signup(client, "carl")  # a user, but no member
    return s, people


def test_every_target_kind_and_the_filters(client, team):
    s, people = team
    first, second = sorted(s.image_ids.values())[:2]
    eid = client.post(f"/api/v1/projects/{s.pid}/edits", json={"base_version_id": s.vid},
                      headers=s.owner).json()["id"]
    targets = [{"kind": "image", "id": first}, {"kind": "pair", "image_ids": [second, first]},
               {"kind": "version", "id": s.vid}, {"kind": "edit_set", "id": eid}, {"kind": "project"}]
    made = [post(client, s, people["vic"], t, body=f"on {t['kind']}") for t in targets]
    assert made[1]["target"] == {"kind": "pair", "image_ids": [first, second]}  # stored in id order
    assert made[0]["target"] == {"kind": "image", "id": first} and made[4]["target"] == {"kind": "project"}
    assert all(c["author"] == "vic" and c["resolved"] is False and c["parent_id"] is None for c in made)
    listed = client.get(api(s), headers=people["vic"]).json()
    assert [c["id"] for c in listed] == [c["id"] for c in made]  # oldest first, everything
    on_first = client.get(api(s), params={"kind": "image", "id": first}, headers=s.owner).json()
    assert [c["id"] for c in on_first] == [made[0]["id"]]
    pairs = client.get(api(s), params={"kind": "pair", "id": second}, headers=s.owner).json()
    assert [c["id"] for c in pairs] == [made[1]["id"]]
    assert client.patch(api(s, f"/{made[2]['id']}"), json={"resolved": True}, headers=people["ana"]).json()[
        "resolved"] is True
    open_ = client.get(api(s), params={"resolved": "false"}, headers=s.owner).json()
    done = client.get(api(s), params={"resolved": "true"}, headers=s.owner).json()
    assert [c["id"] for c in done] == [made[2]["id"]] and len(open_) == 4


@pytest.mark.parametrize("target, words", [
    ({"kind": "pair", "image_ids": [1]}, "image_ids"),
    ({"kind": "pair", "image_ids": [5, 5]}, "two different"),
    ({"kind": "project", "id": 3}, "no id"),
    ({"kind": "version"}, "needs its id"),
    ({"kind": "image", "id": 3, "image_ids": [1, 2]}, "no image_ids"),
    ({"kind": "camera", "id": 3}, "kind"),
    ({"kind": "version", "id": 999999}, "version 999999 not found"),
])
def test_bad_targets_are_refused_and_nothing_stored(client, team, session, target, words):
    s, people = team
    response = client.post(api(s), json={"target": target, "body": "x"}, headers=s.owner)
    assert response.status_code in (404, 422), response.text
    assert words in response.json()["detail"]
    assert session.query(Comment).count() == 0


def test_replies_stay_on_their_parents_target(client, team, session, store, tiny_reconstruction, tiny_images):
    from tests.factories import make_project, make_version

    s, people = team
    root = post(client, s, people["ana"], {"kind": "version", "id": s.vid})
    reply = post(client, s, people["ben"], {"kind": "version", "id": s.vid}, parent_id=root["id"])
    assert reply["parent_id"] == root["id"]
    wrong = post(client, s, people["ben"], {"kind": "project"}, parent_id=root["id"], status=422)
    assert "parent" in wrong["detail"]
    other = make_project(client, s.owner, "other")
    foreign = make_version(session, store, other, tiny_reconstruction, tiny_images / "images")
    theirs = client.post(f"/api/v1/projects/{other}/comments", headers=s.owner,
                         json={"target": {"kind": "version", "id": foreign.id}, "body": "x"}).json()
    assert post(client, s, people["ben"], {"kind": "project"}, parent_id=theirs["id"], status=404)
    # deleting the root deletes its thread
    assert client.delete(api(s, f"/{root['id']}"), headers=people["ana"]).status_code == 204
    assert client.get(api(s), params={"kind": "version"}, headers=s.owner).json() == []


def notes(client, headers, **params):
    response = client.get("/api/v1/notifications", params=params, headers=headers)
    assert response.status_code == 200, response.text
    return response.json()


def test_a_mention_notifies_the_member_until_read(client, team):
    s, people = team
    first = sorted(s.image_ids.values())[0]
    body = "@ben this camera is on the wrong wall. cc @vic. (mail x@ana.org, not @ana)"
    made = post(client, s, people["ana"], {"kind": "image", "id": first}, body=body)
    got = notes(client, people["ben"], unread="true")
    assert [(n["kind"], n["project_id"]) for n in got] == [("mention", s.pid)]
    assert got[0]["target"] == {"kind": "comment", "id": made["id"], "on": {"kind": "image", "id": first}}
    assert "ana" in got[0]["text"] and got[0]["read"] is False
    assert [n["kind"] for n in notes(client, people["vic"])] == ["mention"]  # "@vic." ends a sentence
    assert notes(client, people["ana"]) == []  # her own @ana notifies nobody
    assert notes(client, people["owner"]) == []  # "x@ana.org" is an address, not a mention
    stranger = client.post("/api/v1/notifications/read", json={"ids": [got[0]["id"]]}, headers=people["vic"])
    assert stranger.json() == {"read": 0}  # another's notification stays unread
    read = client.post("/api/v1/notifications/read", json={"ids": [got[0]["id"]]}, headers=people["ben"])
    assert read.status_code == 200 and read.json() == {"read": 1}
    assert notes(client, people["ben"], unread="true") == []
    assert notes(client, people["ben"])[0]["read"] is True
    # editing the body notifies only the newly mentioned
    client.patch(api(s, f"/{made['id']}"), json={"body": body + " @owner"}, headers=people["ana"])
    assert [n["kind"] for n in notes(client, people["owner"])] == ["mention"]
    assert len(notes(client, people["ben"])) == 1


def test_mentioning_a_non_member_is_422_naming_them(client, team, session):
    s, people = team
    response = client.post(api(s), json={"target": {"kind": "project"}, "body": "ask @carl and @ben"},
                           headers=people["ana"])
    assert response.status_code == 422 and "@carl" in response.json()["detail"]
    assert session.query(Comment).count() == 0 and session.query(Notification).count() == 0


def test_html_is_stored_and_returned_as_text(client, team):
    s, people = team
    body = '<script>alert("x")</script><b>bold</b> & <img src=x onerror=alert(1)>'
    made = post(client, s, people["vic"], {"kind": "project"}, body=body)
    assert made["body"] == body
    assert client.get(api(s), headers=s.owner).json()[0]["body"] == body


def test_who_may_edit_resolve_and_delete(client, team, session):
    s, people = team
    vics = post(client, s, people["vic"], {"kind": "project"}, body="mine")
    anas = post(client, s, people["ana"], {"kind": "project"}, body="hers")
    cases = [  # (who, comment, change, status)
        ("vic", vics, {"body": "mine, edited"}, 200),
        ("vic", vics, {"resolved": True}, 200),
        ("vic", anas, {"resolved": True}, 403),
        ("vic", anas, {"body": "hijacked"}, 403),
        ("owner", anas, {"body": "owners cannot rewrite it either"}, 403),
        ("ben", anas, {"resolved": True}, 200),
        ("ben", anas, {"resolved": False}, 200),
    ]
    for who, comment, change, status in cases:
        response = client.patch(api(s, f"/{comment['id']}"), json=change, headers=people[who])
        assert response.status_code == status, (who, change, response.text)
    assert session.get(Comment, anas["id"]).body == "hers"
    assert client.delete(api(s, f"/{anas['id']}"), headers=people["vic"]).status_code == 403
    assert client.delete(api(s, f"/{anas['id']}"), headers=people["ben"]).status_code == 403
    assert client.delete(api(s, f"/{vics['id']}"), headers=people["vic"]).status_code == 204
    assert client.delete(api(s, f"/{anas['id']}"), headers=s.owner).status_code == 204
    assert session.query(Comment).count() == 0
    log = client.get(f"/api/v1/projects/{s.pid}/activity", params={"action": "comment"}, headers=s.owner)
    ops = [(e["user"], e["detail"]["op"]) for e in reversed(log.json()["items"])]
    assert ops == [("vic", "post"), ("ana", "post"), ("vic", "edit"), ("vic", "resolve"), ("ben", "resolve"),
                   ("ben", "reopen"), ("vic", "delete"), ("owner", "delete")]


def test_notifications_need_a_token_and_stay_within_a_tokens_projects(client, team):
    s, people = team
    assert client.get("/api/v1/notifications").status_code == 401
    assert client.post("/api/v1/notifications/read", json={"ids": []}).status_code == 401
    post(client, s, people["ana"], {"kind": "project"}, body="@ben hello")
    own = client.post("/api/v1/projects", json={"name": "bens"}, headers=people["ben"]).json()["id"]
    limited = client.post("/api/v1/tokens", json={"name": "t", "scope": "write", "projects": [own]},
                          headers=people["ben"]).json()["token"]
    assert notes(client, {"Authorization": f"Bearer {limited}"}) == []
    assert len(notes(client, people["ben"])) == 1
