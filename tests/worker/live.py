"""A live service for tests: the API in-process over a committed database, the worker as a real
`guided-sfm worker` process (filesystem broker or Redis)."""

from __future__ import annotations

import contextlib
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import redis

from guided_sfm.api.app import create_app
from guided_sfm.db.session import make_sessionmaker
from tests.conftest import SECRET, TestClient, make_settings
from tests.required import missing
from worker.celery_app import make_celery, submitter

REDIS_URL = os.environ.get("GUIDED_SFM_TEST_REDIS_URL", "redis://127.0.0.1:6379/15")
FAST_SWEEP = {"sweep_seconds": 2.0, "heartbeat_seconds": 1.0, "stale_seconds": 6.0, "requeue_seconds": 5.0}


def redis_or_skip() -> str:
    try:
        redis.Redis.from_url(REDIS_URL, socket_connect_timeout=2).ping()
    except redis.RedisError as exc:
        missing(f"Redis at {REDIS_URL} is unreachable ({exc}); the Redis worker test needs it")
    return REDIS_URL


class Service:
    """The API in-process (TestClient) and the worker as a real `guided-sfm worker` process."""

    def __init__(self, tmp_path: Path, database_url: str, broker_url: str, **overrides) -> None:
        self.settings = make_settings(tmp_path / "data", database_url, broker_url=broker_url,
                                      **{**FAST_SWEEP, **overrides})
        self.env = {**os.environ, **{f"GUIDED_SFM_{k.upper()}": str(v) for k, v in {
            "data_dir": self.settings.data_dir, "database_url": database_url, "broker_url": broker_url,
            "secret_key": SECRET, **FAST_SWEEP, **overrides}.items()}}
        self.log = tmp_path / "worker.log"
        self.worker: subprocess.Popen | None = None
        self.celery = make_celery(self.settings)
        self.sessions = make_sessionmaker(self.settings)
        app = create_app(self.settings, submitter(self.celery), sessions=self.sessions)
        self.client = TestClient(app)

    def start_worker(self) -> None:
        with open(self.log, "ab") as log:
            self.worker = subprocess.Popen([sys.executable, "-m", "guided_sfm.cli", "worker"], env=self.env,
                                           stdout=log, stderr=log, start_new_session=True)

    def kill_worker(self, sig: int = signal.SIGKILL) -> None:
        """SIGKILL: the whole process group at once. SIGTERM: the leader, then SIGKILL after 30 s."""
        if self.worker is None or self.worker.poll() is not None:
            return
        if sig == signal.SIGKILL:
            os.killpg(self.worker.pid, signal.SIGKILL)
        else:
            os.kill(self.worker.pid, sig)
            with contextlib.suppress(subprocess.TimeoutExpired):
                self.worker.wait(timeout=30)
            with contextlib.suppress(ProcessLookupError):
                os.killpg(self.worker.pid, signal.SIGKILL)
        self.worker.wait(timeout=30)

    def wait_job(self, headers, job_id: int, until, timeout: float) -> dict:
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            job = self.client.get(f"/api/v1/jobs/{job_id}", headers=headers).json()
            if until(job):
                return job
            time.sleep(0.2)
        raise AssertionError(f"job {job_id} still {job} after {timeout} s; worker log:\n"
                             + self.log.read_text()[-3000:])

    def close(self) -> None:
        self.kill_worker(signal.SIGTERM)
        self.client.close()
        self.sessions.kw["bind"].dispose()


def upload(service: Service, headers, pid: int, folder: Path, prefix: str = "") -> None:
    files = [("files", (prefix + p.name, p.read_bytes(), "image/jpeg")) for p in sorted(folder.iterdir())]
    response = service.client.post(f"/api/v1/projects/{pid}/images", files=files, headers=headers)
    assert response.status_code == 201, response.text
