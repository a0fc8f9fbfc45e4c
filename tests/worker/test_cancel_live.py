"""Cancel end to end: a real worker process runs a reconstruction, the API sets the flag, the
worker's heartbeat thread reads it into the cancellation token, the job ends cancelled, and the
project keeps the version it had (no new version row, nothing published, staging cleaned)."""

from __future__ import annotations

import time

from guided_sfm.storage import ArtifactStore
from tests.factories import make_project, signup
from tests.worker.live import upload

HEARTBEAT_S = 0.5  # the flag reaches the token within this (plus a busy database's retry)


def test_cancel_reaches_a_running_worker_and_keeps_the_head(service_factory, tiny_images):
    service = service_factory("filesystem://", heartbeat_seconds=HEARTBEAT_S)
    service.start_worker()
    headers = signup(service.client, "alice")
    pid = make_project(service.client, headers)
    upload(service, headers, pid, tiny_images / "images")
    first = service.client.post(f"/api/v1/projects/{pid}/reconstruct", json={}, headers=headers).json()
    first = service.wait_job(headers, first["id"], lambda j: j["state"] not in ("queued", "running"), 300)
    assert first["state"] == "succeeded", (first, service.log.read_text()[-3000:])
    # more images (the tiny set again under other names): a second run lasts several heartbeats
    upload(service, headers, pid, tiny_images / "images", prefix="again_")
    job = service.client.post(f"/api/v1/projects/{pid}/reconstruct", json={}, headers=headers).json()
    service.wait_job(headers, job["id"], lambda j: j["state"] == "running", 300)
    asked = time.monotonic()
    response = service.client.post(f"/api/v1/jobs/{job['id']}/cancel", headers=headers)
    assert response.status_code == 200 and response.json()["state"] == "running", response.text
    ended = service.wait_job(headers, job["id"], lambda j: j["state"] != "running", 300)
    print(f"cancel asked in stage {response.json()['stage']!r}; job ended {ended['state']} "
          f"after {time.monotonic() - asked:.1f} s")
    assert ended["state"] == "cancelled" and ended["message"] == "cancelled by request", ended
    assert ended["version_id"] is None
    project = service.client.get(f"/api/v1/projects/{pid}", headers=headers).json()
    assert project["head_version_id"] == first["version_id"]
    versions = service.client.get(f"/api/v1/projects/{pid}/versions", headers=headers).json()
    assert [v["id"] for v in versions] == [first["version_id"]]
    store = ArtifactStore(service.settings.artifacts_dir)
    assert len(list((store.project_dir(pid) / "versions").iterdir())) == 1  # nothing published
    assert list((store.project_dir(pid) / "tmp").iterdir()) == []  # the job's staging is gone
