"""Webhooks: who may subscribe which URL, the outbox written with the change, signed deliveries
retried with back-off (sent here by the deliverer's own function to a receiver on 127.0.0.1)."""

import hashlib
import hmac
import json
from dataclasses import replace

import httpx
import pytest

from guided_sfm.actions import webhooks
from guided_sfm.db.models import Project, Webhook, WebhookDelivery, utcnow
from guided_sfm.db.session import make_engine, make_sessionmaker
from tests.factories import add_member, make_project, signup
from tests.receiver import Receiver

PUBLIC = {"example.org": ["93.184.215.14"], "inside.example": ["10.1.2.3"],
          "six.example": ["2606:4700::1111"], "loop.example": ["::1"]}


def fake_dns(host):
    if host not in PUBLIC:
        raise OSError("no such host")
    return PUBLIC[host]


@pytest.mark.parametrize("url, refused", [
    ("https://example.org/hook", None),
    ("http://six.example:8080/x", None),
    ("ftp://example.org/hook", "http(s)"),
    ("https:///nohost", "http(s)"),
    ("http://inside.example/hook", "10.1.2.3"),
    ("http://loop.example/hook", "::1"),
    ("http://nowhere.example/hook", "does not resolve"),
])
def test_url_refusals(url, refused):
    reason = webhooks.refusal(url, allow_private=False, resolver=fake_dns)
    assert reason is None if refused is None else refused in reason


@pytest.mark.parametrize("address", ["127.0.0.1", "169.254.169.254", "192.168.1.1", "172.16.0.1",
                                     "100.64.0.1", "0.0.0.0", "fe80::1", "224.0.0.1"])
def test_every_non_public_address_is_refused_unless_allowed(address):
    def dns(host):
        return [address]

    assert "non-public" in webhooks.refusal("http://x.example/", False, dns)
    assert webhooks.refusal("http://x.example/", True, dns) is None


def test_owner_subscribes_and_private_urls_are_422(client):
    ann = signup(client, "ann")
    pid = make_project(client, ann)
    body = {"url": "http://127.0.0.1:9/hook", "events": ["job_finished"]}
    response = client.post(f"/api/v1/projects/{pid}/webhooks", json=body, headers=ann)
    assert response.status_code == 422 and "WEBHOOK_ALLOW_PRIVATE" in response.json()["detail"]
    bad = client.post(f"/api/v1/projects/{pid}/webhooks", json={**body, "url": "file:///etc/passwd"},
                      headers=ann)
    assert bad.status_code == 422 and "http(s)" in bad.json()["detail"]
    unknown = client.post(f"/api/v1/projects/{pid}/webhooks", json={**body, "events": ["boom"]}, headers=ann)
    assert unknown.status_code == 422
    assert client.get(f"/api/v1/projects/{pid}/webhooks", headers=ann).json() == []


def test_only_owners_manage_webhooks(client, settings):
    client.app.state.settings = replace(settings, webhook_allow_private=True, secret_key="x" * 32)
    ann, bob = signup(client, "ann"), signup(client, "bob")
    pid = make_project(client, ann)
    add_member(client, ann, pid, "bob", "editor")
    body = {"url": "http://127.0.0.1:9/hook", "events": ["job_finished", "version_created"]}
    assert client.post(f"/api/v1/projects/{pid}/webhooks", json=body, headers=bob).status_code == 403
    made = client.post(f"/api/v1/projects/{pid}/webhooks", json=body, headers=ann)
    assert made.status_code == 201 and len(made.json()["secret"]) >= 16
    listed = client.get(f"/api/v1/projects/{pid}/webhooks", headers=ann).json()
    assert [h["id"] for h in listed] == [made.json()["id"]] and "secret" not in listed[0]
    other = make_project(client, bob)
    wid = made.json()["id"]
    assert client.delete(f"/api/v1/projects/{other}/webhooks/{wid}", headers=bob).status_code == 404
    assert client.delete(f"/api/v1/projects/{pid}/webhooks/{wid}", headers=ann).status_code == 204
    assert client.get(f"/api/v1/projects/{pid}/webhooks", headers=ann).json() == []


def test_emit_queues_only_for_subscribers_of_the_event(session, client):
    ann = signup(client, "ann")
    pid = make_project(client, ann)
    session.add_all([Webhook(project_id=pid, url="http://a/", events=["job_finished"], secret="s" * 16),
                     Webhook(project_id=pid, url="http://b/", events=["version_created"], secret="t" * 16)])
    session.commit()
    assert webhooks.emit(session, pid, "job_finished", {"job_id": 1}) == 1
    session.commit()
    rows = session.query(WebhookDelivery).all()
    assert [json.loads(r.body)["event"] for r in rows] == ["job_finished"]
    assert json.loads(rows[0].body)["data"] == {"job_id": 1} and json.loads(rows[0].body)["project_id"] == pid


def test_delivery_is_signed_and_retried_until_accepted(session, client, settings):
    settings = replace(settings, webhook_allow_private=True, webhook_retry_seconds=0.0)
    ann = signup(client, "ann")
    pid = make_project(client, ann)
    with Receiver([500, 503, 200]) as receiver:
        hook = webhooks.create(session, pid, receiver.url, ["job_finished"], "a-secret-of-sixteen", True)
        webhooks.emit(session, pid, "job_finished", {"job_id": 7})
        session.commit()
        with httpx.Client() as http:
            made = sum(webhooks.deliver_due(session, settings, http) for _ in range(5))
        received = receiver.wait_for(3, timeout=10)
    assert made == 3
    headers, body = received[-1]
    expected = "sha256=" + hmac.new(b"a-secret-of-sixteen", body, hashlib.sha256).hexdigest()
    assert headers["X-Guided-SFM-Signature"] == expected
    assert json.loads(body)["data"] == {"job_id": 7}
    row = webhooks.deliveries(session, hook)[0]
    assert (row.state, row.attempts, row.status_code, row.answer) == ("ok", 3, 200, "thanks")


def test_delivery_gives_up_after_its_attempts_with_back_off(session, client, settings):
    settings = replace(settings, webhook_allow_private=True, webhook_retry_seconds=3600.0, webhook_attempts=2)
    ann = signup(client, "ann")
    pid = make_project(client, ann)
    with Receiver([500]) as receiver, httpx.Client() as http:
        hook = webhooks.create(session, pid, receiver.url, ["version_created"], None, True)
        webhooks.emit(session, pid, "version_created", {})
        session.commit()
        assert webhooks.deliver_due(session, settings, http) == 1
        assert webhooks.deliver_due(session, settings, http) == 0  # backing off for an hour
        row = webhooks.deliveries(session, hook)[0]
        row.next_attempt_at = row.at  # the hour has passed
        session.commit()
        assert webhooks.deliver_due(session, settings, http) == 1
    row = webhooks.deliveries(session, hook)[0]
    assert (row.state, row.attempts, row.status_code) == ("failed", 2, 500)
    listed = client.get(f"/api/v1/projects/{pid}/webhooks/{hook.id}/deliveries", headers=ann).json()
    assert [(d["ok"], d["attempts"], d["status_code"]) for d in listed] == [(False, 2, 500)]


def test_two_senders_never_take_the_same_attempt(committed_database):
    """Both saw the delivery due; the compare-and-set on attempts lets one of them send it."""
    engine = make_engine(committed_database)
    sessions = make_sessionmaker(engine)
    with sessions() as setup:
        project = Project(name="p")
        setup.add(project)
        setup.commit()
        webhooks.create(setup, project.id, "http://127.0.0.1:9/", ["job_finished"], None, True)
        webhooks.emit(setup, project.id, "job_finished", {})
        setup.commit()
    with sessions() as first, sessions() as second:
        (delivery_id,) = webhooks.due(first, utcnow())
        seen = first.get(WebhookDelivery, delivery_id)  # the first sender has read it as due...
        first.commit()  # (ending its read: SQLite would refuse its later write outright)
        won = webhooks.claim(second, delivery_id, utcnow(), lease=60)  # ...the second claims first
        lost = webhooks.claim(first, delivery_id, utcnow(), lease=60)
    engine.dispose()
    assert seen is not None and won is not None and won.attempts == 1 and lost is None


def test_submit_and_review_are_queued_for_subscribers(client, session, reconstructed):
    s = reconstructed
    ben = signup(client, "ben")
    add_member(client, s.owner, s.pid, "ben", "editor")
    session.add(Webhook(project_id=s.pid, url="http://a/", events=["edit_submitted", "edit_reviewed"],
                        secret="s" * 16))
    session.commit()
    eid = client.post(f"/api/v1/projects/{s.pid}/edits", json={"base_version_id": s.vid},
                      headers=s.owner).json()["id"]
    assert client.post(f"/api/v1/projects/{s.pid}/edits/{eid}/submit", headers=s.owner).status_code == 200
    reviewed = client.post(f"/api/v1/projects/{s.pid}/edits/{eid}/reviews", headers=ben,
                           json={"verdict": "request_changes", "comment": "wrong wall"})
    assert reviewed.status_code == 201
    sent = [json.loads(row.body) for row in session.query(WebhookDelivery).order_by(WebhookDelivery.id)]
    assert [(b["event"], b["data"]["edit_set_id"]) for b in sent] == [("edit_submitted", eid),
                                                                      ("edit_reviewed", eid)]
    assert sent[1]["data"]["verdict"] == "request_changes" and sent[1]["data"]["by"] == "ben"
