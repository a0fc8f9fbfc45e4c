"""The REST loop with workers on several hosts (design.md v1.1, "Storage for workers on several
hosts"): the API and two real worker processes, each with a data dir and a TMPDIR of its own (no
shared filesystem), Postgres, Redis and an S3 endpoint (moto's server over HTTP). Two projects are
reconstructed and corrected at once, so both workers run jobs and a project's apply may run where
its reconstruction did not. Every job must succeed, and afterwards no project file may be anywhere
but in the store: not in any data dir, not in any scratch dir. The same loop on the data dir (one
shared data dir, the embedded layout) is the baseline for the transfer overhead."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest
from sqlalchemy import select

from guided_sfm.db.models import Version
from guided_sfm.storage import open_store
from tests.factories import make_project, signup
from tests.s3server import CREDENTIALS
from tests.worker.live import Service, redis_or_skip, upload

JOB_TIMEOUT = 300.0
PROJECT_FILES = (".jpg", ".jpeg", ".png", ".db", ".bin", ".zip", ".ply")  # images, databases, models


def postgres_or_skip() -> None:
    """Workers on several hosts share a database: this runs in the Postgres pass of `make test`."""
    if not os.environ.get("GUIDED_SFM_TEST_DATABASE_URL", "").startswith("postgresql"):
        pytest.skip("runs on Postgres only (GUIDED_SFM_TEST_DATABASE_URL): SQLite is one host's file")


class Worker:
    """A `guided-sfm worker` process with its own data dir and TMPDIR (as on a host of its own)."""

    def __init__(self, service: Service, root: Path, name: str, env: dict[str, str]) -> None:
        self.name, self.data_dir, self.temp_dir = name, root / f"{name}-data", root / f"{name}-tmp"
        self.temp_dir.mkdir(parents=True, exist_ok=True)  # a restarted worker: the same host
        self.log = root / f"{name}.log"
        env = {**service.env, **env, "TMPDIR": str(self.temp_dir)}
        if "GUIDED_SFM_ARTIFACTS_URL" in env:
            env["GUIDED_SFM_DATA_DIR"] = str(self.data_dir)
        with open(self.log, "ab") as log:
            self.process = subprocess.Popen([sys.executable, "-m", "guided_sfm.cli", "worker"], env=env,
                                            stdout=log, stderr=log, start_new_session=True)

    def scratch(self) -> list[Path]:
        root = self.temp_dir / "guided-sfm-scratch"
        return sorted(root.iterdir()) if root.is_dir() else []

    def jobs_run(self) -> int:
        return self.log.read_text(errors="replace").count(" produced version ")

    def stop(self) -> None:
        if self.process.poll() is None:
            os.killpg(self.process.pid, signal.SIGTERM)
            try:
                self.process.wait(timeout=30)
            except subprocess.TimeoutExpired:
                os.killpg(self.process.pid, signal.SIGKILL)
                self.process.wait(timeout=30)


@pytest.fixture
def loop(request, tmp_path, monkeypatch, service_factory):
    """(service, workers, api temp dir, worker env) for the backend named by the test's parameter."""
    postgres_or_skip()
    env, overrides = {}, {}
    if request.param == "s3":
        server = request.getfixturevalue("moto_server")
        env = dict(CREDENTIALS)
        for name, value in env.items():
            monkeypatch.setenv(name, value)  # the in-process API's boto3 reads them too
        overrides = {"artifacts_url": f"s3://{server.new_bucket()}/guided-sfm",
                     "s3_endpoint_url": server.url}
    api_tmp = tmp_path / "api-tmp"
    api_tmp.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(api_tmp))  # the API's scratch, checked empty below
    service = service_factory(redis_or_skip(), **overrides)
    workers = [Worker(service, tmp_path, f"worker{i}", env) for i in (1, 2)]
    yield service, workers, api_tmp, env
    for worker in workers:
        worker.stop()


def run_jobs(service: Service, headers, posted: list, workers: list[Worker]) -> list[dict]:
    """Wait for the jobs; each must succeed, and then no worker may hold scratch."""
    done = []
    for response in posted:
        assert response.status_code == 202, response.text
        job = service.wait_job(headers, response.json()["id"],
                               lambda j: j["state"] not in ("queued", "running"), JOB_TIMEOUT)
        logs = "".join(w.log.read_text()[-2000:] for w in workers)
        assert job["state"] == "succeeded", f"job {job['id']} ({job['kind']}): {job['error']}\n{logs}"
        done.append(job)
    # a job's row ends inside its scratch block: the folder goes a moment after the API says so
    wait_for(lambda: not any(w.scratch() for w in workers), "the workers to empty their scratch", 30.0)
    return done


def moved_camera_edit(client, headers, pid: int, version: int) -> dict:
    scene = client.get(f"/api/v1/projects/{pid}/versions/{version}/scene", headers=headers).json()
    camera = next(c for c in scene["cameras"] if c["registered"])
    pairs = client.get(f"/api/v1/projects/{pid}/versions/{version}/pairs", headers=headers).json()
    cut = [pairs[-1]["image_id1"], pairs[-1]["image_id2"]]
    return {"base_version_id": version, "delete_pairs": [cut],
            "cameras": [{"image_id": camera["image_id"], "x": camera["x"] + 0.05, "y": camera["y"],
                         "yaw_deg": camera["yaw_deg"]}]}


def served_files_match(client, headers, pid: int, folder: Path) -> None:
    images = client.get(f"/api/v1/projects/{pid}/images", headers=headers).json()
    first = images[0]
    original = client.get(f"/api/v1/projects/{pid}/images/{first['id']}/file", headers=headers)
    assert original.status_code == 200 and original.content == (folder / first["name"]).read_bytes()
    thumb = client.get(f"/api/v1/projects/{pid}/images/{first['id']}/thumbnail", headers=headers)
    assert thumb.status_code == 200 and thumb.content[:2] == b"\xff\xd8"  # a JPEG


def project_files(folder: Path) -> list[str]:
    return sorted(str(p) for p in folder.rglob("*") if p.is_file() and p.suffix.lower() in PROJECT_FILES
                  and "broker" not in p.parts)


@pytest.mark.services
@pytest.mark.parametrize("loop", ["s3", "data_dir"], indirect=True)
def test_rest_loop_with_two_workers_and_no_shared_files(loop, tiny_images, record_property):
    service, workers, api_tmp, _ = loop
    client, headers = service.client, signup(service.client, "alice")
    started = time.monotonic()
    pids = [make_project(client, headers, f"p{i}") for i in (1, 2)]
    for pid in pids:
        upload(service, headers, pid, tiny_images / "images")
    built = run_jobs(service, headers, [client.post(f"/api/v1/projects/{pid}/reconstruct", json={},
                                                    headers=headers) for pid in pids], workers)
    applies = []
    for pid, job in zip(pids, built, strict=True):
        body = moved_camera_edit(client, headers, pid, job["version_id"])
        eid = client.post(f"/api/v1/projects/{pid}/edits", json=body, headers=headers).json()["id"]
        preview = client.get(f"/api/v1/projects/{pid}/edits/{eid}/preview", headers=headers).json()
        assert body["delete_pairs"][0] in preview["pairs_to_delete"], preview
        applies.append(client.post(f"/api/v1/projects/{pid}/edits/{eid}/apply", json={"remap": True},
                                   headers=headers))
    applied = run_jobs(service, headers, applies, workers)
    elapsed = time.monotonic() - started
    for pid, job in zip(pids, applied, strict=True):
        project = client.get(f"/api/v1/projects/{pid}", headers=headers).json()
        assert project["head_version_id"] == job["version_id"]
        export = client.get(f"/api/v1/projects/{pid}/versions/{job['version_id']}/export?format=colmap",
                            headers=headers)
        assert export.status_code == 200 and export.content[:2] == b"PK"
        served_files_match(client, headers, pid, tiny_images / "images")
    record_property("loop_seconds", round(elapsed, 1))
    print(f"\nREST loop ({loop_name(service)}): {elapsed:.1f} s; jobs per worker "
          f"{[w.jobs_run() for w in workers]}")
    assert all(w.jobs_run() >= 1 for w in workers), "both workers should have run a job"
    assert list(api_tmp.iterdir()) in ([], [api_tmp / "guided-sfm-scratch"])
    assert not [p for p in (api_tmp / "guided-sfm-scratch").glob("*")], "the API kept scratch"
    if service.settings.artifacts_url:
        stray = [f for folder in (service.settings.data_dir, *(w.data_dir for w in workers))
                 for f in project_files(folder)]
        assert stray == [], f"project files outside the store: {stray}"


def loop_name(service: Service) -> str:
    return "S3" if service.settings.artifacts_url else "data dir"


@pytest.mark.services
@pytest.mark.parametrize("loop", ["s3"], indirect=True)
def test_a_worker_killed_mid_job_leaves_no_partial_version(loop, tiny_images, tmp_path):
    """SIGKILL the worker running a reconstruction (found by the scratch dir on its host): the job
    re-runs on the other worker, one version is visible, and whatever the killed worker left in
    the store is no readable version; its scratch goes when a worker on its host starts again."""
    service, workers, _, env = loop
    client, headers = service.client, signup(service.client, "alice")
    pid = make_project(client, headers)
    upload(service, headers, pid, tiny_images / "images")
    job = client.post(f"/api/v1/projects/{pid}/reconstruct", json={}, headers=headers).json()
    victim = wait_for(lambda: next((w for w in workers if w.scratch()), None), "a worker to start the job")
    os.killpg(victim.process.pid, signal.SIGKILL)
    victim.process.wait(timeout=30)
    done = service.wait_job(headers, job["id"], lambda j: j["state"] not in ("queued", "running"),
                            JOB_TIMEOUT)
    assert done["state"] == "succeeded", done
    assert victim.jobs_run() == 0 and sum(w.jobs_run() for w in workers) == 1
    versions = client.get(f"/api/v1/projects/{pid}/versions", headers=headers).json()
    assert [v["id"] for v in versions] == [done["version_id"]]
    store = open_store(service.settings)
    with service.sessions() as session:
        rows = set(session.scalars(select(Version.path).where(Version.project_id == pid)))
    for name in store.children(f"projects/{pid}/versions"):
        if f"projects/{pid}/versions/{name}" not in rows:  # a half-published version: unreadable
            with pytest.raises(FileNotFoundError), store.reading(f"projects/{pid}/versions/{name}"):
                pass
    assert victim.scratch(), "the killed worker's scratch is still on its host"
    workers.append(Worker(service, tmp_path, victim.name, env))
    wait_for(lambda: not victim.scratch(), "the restarted worker to clear the dead one's scratch")


def wait_for(found, what: str, timeout: float = 120.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if value := found():
            return value
        time.sleep(0.05)
    raise AssertionError(f"waited {timeout} s for {what}")
