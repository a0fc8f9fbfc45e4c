"""Webhooks end to end: a real worker process runs a job; its deliverer posts job_finished and
version_created, signed, to a receiver on 127.0.0.1 (allowed by the setting)."""

import hashlib
import hmac
import json

from tests.factories import make_project, signup
from tests.receiver import Receiver
from tests.worker.live import upload

SECRET = "receiver-shared-secret"


def test_a_finished_job_is_delivered_signed_and_retried(service_factory, tiny_images):
    service = service_factory("filesystem://", webhook_allow_private=True, webhook_retry_seconds=0.5)
    client, headers = service.client, signup(service.client, "ann")
    pid = make_project(client, headers)
    upload(service, headers, pid, tiny_images / "images")
    with Receiver([503, 200]) as receiver:
        body = {"url": receiver.url, "events": ["job_finished", "version_created"], "secret": SECRET}
        wid = client.post(f"/api/v1/projects/{pid}/webhooks", json=body, headers=headers).json()["id"]
        service.start_worker()
        job = client.post(f"/api/v1/projects/{pid}/reconstruct", json={}, headers=headers).json()
        done = service.wait_job(headers, job["id"], lambda j: j["state"] not in ("queued", "running"), 300)
        assert done["state"] == "succeeded", done
        received = receiver.wait_for(3, timeout=60)  # one refused (503), then both accepted
    events = {}
    for sent_headers, raw in received:
        expected = "sha256=" + hmac.new(SECRET.encode(), raw, hashlib.sha256).hexdigest()
        assert sent_headers["X-Guided-SFM-Signature"] == expected
        events.setdefault(json.loads(raw)["event"], []).append(json.loads(raw))
    assert set(events) == {"job_finished", "version_created"}
    assert events["job_finished"][-1]["data"]["version_id"] == done["version_id"]
    assert events["version_created"][-1]["data"] == {**events["version_created"][-1]["data"],
                                                     "version_id": done["version_id"], "is_head": True}
    listed = client.get(f"/api/v1/projects/{pid}/webhooks/{wid}/deliveries", headers=headers).json()
    assert sorted(d["attempts"] for d in listed) == [1, 2] and all(d["ok"] for d in listed)
