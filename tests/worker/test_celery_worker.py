"""A real Celery worker process: embedded (filesystem broker + SQLite) and Redis; SIGKILL recovery."""

from __future__ import annotations

import signal
import time
from pathlib import Path

import pytest

from tests.factories import make_project, signup
from tests.worker.live import Service, redis_or_skip, upload


def reconstruct_tiny(service: Service, tiny_images: Path) -> tuple[dict, int, dict]:
    headers = signup(service.client, "alice")
    pid = make_project(service.client, headers)
    upload(service, headers, pid, tiny_images / "images")
    job = service.client.post(f"/api/v1/projects/{pid}/reconstruct", json={}, headers=headers).json()
    done = service.wait_job(headers, job["id"], lambda j: j["state"] not in ("queued", "running"), 180)
    return headers, pid, done


def test_embedded_worker_runs_a_job(service_factory, tmp_path, tiny_images):
    sqlite_url = f"sqlite:///{tmp_path / 'embedded.db'}"
    from guided_sfm.db.migrate import upgrade

    upgrade(sqlite_url)
    service = service_factory("filesystem://", database_url=sqlite_url)
    service.start_worker()
    headers, pid, job = reconstruct_tiny(service, tiny_images)
    assert job["state"] == "succeeded", job
    head = service.client.get(f"/api/v1/projects/{pid}", headers=headers).json()["head_version_id"]
    assert head == job["version_id"]


@pytest.mark.services
def test_redis_worker_runs_a_job(service_factory, tiny_images):
    service = service_factory(redis_or_skip())
    service.start_worker()
    headers, pid, job = reconstruct_tiny(service, tiny_images)
    assert job["state"] == "succeeded", job


def test_lost_message_is_resent_by_the_sweeper(service_factory, tiny_images, tmp_path):
    """A job committed while no worker ran and whose message vanished still runs."""
    service = service_factory("filesystem://")
    headers = signup(service.client, "alice")
    pid = make_project(service.client, headers)
    upload(service, headers, pid, tiny_images / "images")
    service.client.app.state.submit = lambda job_id: None  # the message is lost
    job = service.client.post(f"/api/v1/projects/{pid}/reconstruct", json={}, headers=headers).json()
    service.start_worker()
    done = service.wait_job(headers, job["id"], lambda j: j["state"] == "succeeded", 180)
    assert done["version_id"]


@pytest.mark.slow
def test_sigkill_during_mapping_fails_the_job_and_keeps_the_head(service_factory, tiny_images,
                                                                  murals_images):
    service = service_factory("filesystem://", max_attempts=1)
    service.start_worker()
    headers, pid, first = reconstruct_tiny(service, tiny_images)
    assert first["state"] == "succeeded", first
    upload(service, headers, pid, murals_images / "images", prefix="m_")
    body = {"matcher": "sequential"}  # reach mapping sooner; mapping 64 images still takes a while
    job = service.client.post(f"/api/v1/projects/{pid}/reconstruct", json=body, headers=headers).json()
    service.wait_job(headers, job["id"], lambda j: j["stage"] == "map", 600)
    service.kill_worker(signal.SIGKILL)
    killed_at = time.monotonic()
    service.start_worker()  # as `serve` does; its sweeper finds the silent job
    # generous on a loaded machine; what it took is printed (stale after 6 s, a sweep every 2 s)
    ended = service.wait_job(headers, job["id"], lambda j: j["state"] != "running", 600)
    settings = service.settings
    print(f"the job failed {time.monotonic() - killed_at:.1f} s after SIGKILL (stale after "
          f"{settings.stale_seconds:.0f} s, a sweep every {settings.sweep_seconds:.0f} s)")
    assert ended["state"] == "failed" and "stopped" in ended["error"], ended
    project = service.client.get(f"/api/v1/projects/{pid}", headers=headers).json()
    assert project["head_version_id"] == first["version_id"]
    versions = service.client.get(f"/api/v1/projects/{pid}/versions", headers=headers).json()
    assert [v["id"] for v in versions] == [first["version_id"]]
