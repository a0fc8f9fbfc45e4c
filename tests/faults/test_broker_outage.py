"""A broker outage, with a redis-server of the test's own and a real worker: jobs queued while it is
down, past the sweep period, each run exactly once after it comes back; the sweeper survives."""

from __future__ import annotations

import shutil
import subprocess
import time

import pytest

from tests.factories import make_project, signup
from tests.faults.live_api import free_port


class OwnRedis:
    def __init__(self, port: int) -> None:
        self.port, self.process = port, None

    def start(self) -> None:
        self.process = subprocess.Popen(["redis-server", "--port", str(self.port), "--save", "",
                                         "--appendonly", "no", "--bind", "127.0.0.1"],
                                        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(0.5)

    def stop(self) -> None:
        if self.process is not None and self.process.poll() is None:
            self.process.terminate()
            self.process.wait(timeout=30)


def test_jobs_queued_during_a_broker_outage_run_exactly_once(service_factory):
    if shutil.which("redis-server") is None:
        pytest.skip("redis-server is not installed")
    redis = OwnRedis(free_port())
    redis.start()
    try:
        service = service_factory(f"redis://127.0.0.1:{redis.port}/0")
        service.start_worker()
        headers = signup(service.client, "ops")
        time.sleep(5)  # the worker is connected and its sweeper running
        redis.stop()
        ids = []
        for name in ("a", "b"):  # the API's enqueue fails; the rows stay queued
            response = service.client.post(f"/api/v1/projects/{make_project(service.client, headers, name)}"
                                           "/reconstruct", json={}, headers=headers)
            assert response.status_code == 202, response.text
            ids.append(response.json()["id"])
        time.sleep(3 * service.settings.sweep_seconds)  # sweeps fail meanwhile
        redis.start()  # empty: every message sent before is gone
        for job_id in ids:
            job = service.wait_job(headers, job_id, lambda j: j["state"] not in ("queued", "running"), 120)
            assert job["state"] == "failed" and "at least 2 images" in job["error"], job
        time.sleep(2 * service.settings.sweep_seconds)  # resent messages arriving late change nothing
        with service.sessions() as session:
            from guided_sfm.db.models import Job

            assert {job.attempts for job in session.query(Job).filter(Job.id.in_(ids))} == {1}
        assert service.worker.poll() is None
    finally:
        redis.stop()
