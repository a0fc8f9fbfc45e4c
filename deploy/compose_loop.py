"""The REST loop against a running compose stack (`make compose-up` first), then proof that the
jobs ran in worker containers and the project lives in the store.

    .venv/bin/python deploy/compose_loop.py [--url http://127.0.0.1:8000] [--layout NAME]

Signs up a fresh user, creates a project, uploads the images of `guided-sfm sample` (a zip),
reconstructs, moves one camera in an edit set, applies it with remap; waits for each job, printing
its stage and progress. Then asks the engine (docker where `docker info` works, else podman) for
the worker containers (one or more): their hostnames, which of them ran each job (its log's
"job N (KIND) produced version V" line, V the job's version), the Celery workers answering on the
stack's broker (all must be worker containers), the files each app container (api and workers)
keeps in its data and temp dirs, and, with an S3 store, the project's objects in it (through the
api container's boto3). The last stdout line is a JSON summary; the exit status is 0 only when
every job succeeded and every check held (`failures` lists the rest).
"""

from __future__ import annotations

import argparse
import io
import json
import os
import re
import secrets
import socket
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.parse
import urllib.request
import uuid
import zipfile
from datetime import datetime
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PROJECT = "guided-sfm"  # docker-compose.yml's name
JOB_TIMEOUT = 1800.0


class Api:
    def __init__(self, url: str) -> None:
        self.base, self.token = url.rstrip("/") + "/api/v1", None

    def call(self, method: str, path: str, body: object = None, form: dict | None = None,
             files: tuple[str, str, bytes] | None = None) -> object:
        headers, data = {}, None
        if self.token:
            headers["Authorization"] = f"Bearer {self.token}"
        if files:
            data, headers["Content-Type"] = multipart(*files)
        elif form is not None:
            data = urllib.parse.urlencode(form).encode()
            headers["Content-Type"] = "application/x-www-form-urlencoded"
        elif body is not None:
            data, headers["Content-Type"] = json.dumps(body).encode(), "application/json"
        request = urllib.request.Request(self.base + path, data=data, headers=headers, method=method)
        try:
            with urllib.request.urlopen(request, timeout=120) as response:
                raw = response.read()
        except urllib.error.HTTPError as exc:
            raise SystemExit(f"{method} {path}: {exc.code} {exc.read().decode(errors='replace')}") from exc
        return json.loads(raw) if raw else None

    def wait(self, job: dict) -> dict:
        start, last = time.monotonic(), None
        while job["state"] in ("queued", "running"):
            if time.monotonic() - start > JOB_TIMEOUT:
                raise SystemExit(f"job {job['id']} still {job['state']} after {JOB_TIMEOUT:.0f} s")
            shown = (job["state"], job["stage"], round(job["progress"], 2))
            if shown != last:
                print(f"  job {job['id']} {job['kind']}: {shown[0]} {shown[1]} {shown[2]:.0%}", flush=True)
                last = shown
            time.sleep(2)
            job = self.call("GET", f"/jobs/{job['id']}")
        job["wall_seconds"] = round(time.monotonic() - start, 1)
        print(f"  job {job['id']} {job['kind']}: {job['state']} after {job['wall_seconds']} s "
              f"{job['error'] or ''}", flush=True)
        return job


def multipart(field: str, filename: str, content: bytes) -> tuple[bytes, str]:
    boundary = uuid.uuid4().hex
    head = (f"--{boundary}\r\nContent-Disposition: form-data; name=\"{field}\"; filename=\"{filename}\"\r\n"
            "Content-Type: application/zip\r\n\r\n").encode()
    return head + content + f"\r\n--{boundary}--\r\n".encode(), f"multipart/form-data; boundary={boundary}"


def sample_zip(layout: str | None, work: Path) -> bytes:
    command = [str(Path(sys.executable).with_name("guided-sfm")), "sample", str(work / "sample")]
    command += ["--layout", layout] if layout else []
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        for image in sorted((work / "sample" / "images").iterdir()):
            archive.write(image, image.name)
    return buffer.getvalue()


def moved_camera(scene: dict) -> dict:
    """The first placed camera, moved onto the placed camera farthest from it and turned round: the
    rule then deletes pairs, so the apply re-maps for real."""
    placed = [c for c in scene["cameras"] if c.get("x") is not None]
    camera = placed[0]
    far = max(placed, key=lambda c: (c["x"] - camera["x"]) ** 2 + (c["y"] - camera["y"]) ** 2)
    return {"image_id": camera["image_id"], "x": far["x"], "y": far["y"],
            "yaw_deg": camera["yaw_deg"] + 180.0}


def rest_loop(api: Api, layout: str | None) -> dict:
    username, password = f"loop-{secrets.token_hex(4)}", secrets.token_urlsafe(16)
    api.call("POST", "/users", {"username": username, "password": password})
    login = api.call("POST", "/auth/token", form={"username": username, "password": password})
    api.token = login["access_token"]
    project = api.call("POST", "/projects", {"name": f"compose loop {username}"})
    pid = project["id"]
    with tempfile.TemporaryDirectory() as work:
        images = api.call("POST", f"/projects/{pid}/images", files=("files", "images.zip",
                                                                    sample_zip(layout, Path(work))))
    print(f"project {pid}: {len(images)} images uploaded", flush=True)
    jobs = [api.wait(api.call("POST", f"/projects/{pid}/reconstruct", {}))]
    if jobs[-1]["state"] != "succeeded":
        return {"project": pid, "jobs": jobs}
    first = jobs[-1]["version_id"]
    camera = moved_camera(api.call("GET", f"/projects/{pid}/versions/{first}/scene"))
    edit = api.call("POST", f"/projects/{pid}/edits", {"base_version_id": first, "cameras": [camera]})
    preview = api.call("GET", f"/projects/{pid}/edits/{edit['id']}/preview")
    print(f"edit set {edit['id']} moves image {camera['image_id']}: "
          f"{len(preview.get('pairs_to_delete', []))} pairs to delete", flush=True)
    jobs.append(api.wait(api.call("POST", f"/projects/{pid}/edits/{edit['id']}/apply", {"remap": True})))
    versions = api.call("GET", f"/projects/{pid}/versions")
    return {"project": pid, "images": len(images), "moved_image_id": camera["image_id"],
            "pairs_to_delete": len(preview.get("pairs_to_delete", [])), "jobs": jobs,
            "versions": [v["id"] for v in versions]}


class Engine:
    """docker compose where `docker info` works, else podman with deploy/podman's settings."""

    def __init__(self) -> None:
        self.docker = subprocess.run(["docker", "info"], capture_output=True).returncode == 0
        self.env = {**os.environ, "CONTAINERS_CONF": str(ROOT / "deploy/podman/containers.conf")}
        self.tool = "docker" if self.docker else "podman"

    def run(self, *args: str) -> str:
        done = subprocess.run([self.tool, *args], capture_output=True, text=True, env=self.env, cwd=ROOT)
        if done.returncode:
            raise SystemExit(f"{self.tool} {' '.join(args[:2])}: {done.stderr.strip()}")
        return done.stdout + done.stderr

    def containers(self, service: str) -> list[str]:
        """The running containers of a service (several once workers are scaled)."""
        if self.docker:
            return self.run("compose", "ps", "-q", service).split()
        labels = [f"label=io.podman.compose.project={PROJECT}", f"label=com.docker.compose.service={service}"]
        return self.run("ps", *[arg for label in labels for arg in ("--filter", label)],
                        "--format", "{{.Names}}").split()

    def python(self, container: str, code: str) -> str:
        return self.run("exec", container, "python", "-c", code).strip()


PING = ("from guided_sfm.settings import Settings; from worker.celery_app import make_celery; import json; "
        "print(json.dumps([n for r in make_celery(Settings.from_env()).control.ping(timeout=5) for n in r]))")
HOSTNAME = "import socket; print(socket.gethostname())"
# Files a container of the app holds outside the store: its data dir and its temp dir (scratch).
LEFT_FILES = ("import os, tempfile, json; print(json.dumps(sorted(os.path.join(d, f) for top in "
              "(os.environ.get('GUIDED_SFM_DATA_DIR', '/data'), tempfile.gettempdir()) "
              "for d, _, fs in os.walk(top) for f in fs)))")


def produced_versions(log: str) -> dict[int, int]:
    """Job id -> version id, from the runner's "job N (KIND) produced version V" lines of a worker's log."""
    found = re.finditer(r"\bjob (\d+) \(\w+\) produced version (\d+)", log)
    return {int(match.group(1)): int(match.group(2)) for match in found}


def worker_of_each_job(engine: Engine, jobs: list[dict]) -> dict[int, str | None]:
    """The worker container whose log says it produced each job's version: the job ran there."""
    ran_in: dict[int, str | None] = {job["id"]: None for job in jobs}
    version_of = {job["id"]: job["version_id"] for job in jobs}
    for container in engine.containers("worker"):
        for job_id, version_id in produced_versions(engine.run("logs", container)).items():
            if job_id in ran_in and version_of[job_id] == version_id:
                ran_in[job_id] = container
    return ran_in


def container_checks(engine: Engine, jobs: list[dict]) -> dict:
    workers = engine.containers("worker")
    if not workers:
        raise SystemExit(f"no running worker container ({engine.tool})")
    hostnames = {container: engine.python(container, HOSTNAME) for container in workers}
    api = engine.containers("api")[0]
    answering = json.loads(engine.python(api, PING).splitlines()[-1])
    return {"engine": engine.tool, "worker_hostnames": hostnames, "broker_workers": answering,
            "job_containers": worker_of_each_job(engine, jobs),
            "files_left": {c: json.loads(engine.python(c, LEFT_FILES)) for c in [api, *workers]},
            "worker_processes": engine.run("top", workers[0]).strip().splitlines()}


def store_keys(engine: Engine, project_id: int) -> dict[str, int] | None:
    """Objects of the project in the S3 store by kind (images, versions, ...); None without S3."""
    api = engine.containers("api")[0]
    code = STORE_KEYS.replace("PROJECT_ID", str(project_id))
    out = engine.python(api, code).splitlines()[-1]
    return json.loads(out)


STORE_KEYS = """
import collections, json, os, urllib.parse
url = os.environ.get('GUIDED_SFM_ARTIFACTS_URL', '')
if not url.startswith('s3://'):
    print('null'); raise SystemExit
import boto3
parts = urllib.parse.urlsplit(url)
prefix = (parts.path.strip('/') + '/' if parts.path.strip('/') else '') + 'projects/PROJECT_ID/'
s3 = boto3.client('s3', endpoint_url=os.environ.get('GUIDED_SFM_S3_ENDPOINT_URL') or None)
kinds = collections.Counter()
for page in s3.get_paginator('list_objects_v2').paginate(Bucket=parts.netloc, Prefix=prefix):
    for item in page.get('Contents', []):
        kinds[item['Key'][len(prefix):].split('/')[0]] += 1
print(json.dumps(kinds))
"""


def job_summary(job: dict) -> dict:
    ran = None
    if job["started_at"] and job["finished_at"]:
        started, finished = (datetime.fromisoformat(job[k]) for k in ("started_at", "finished_at"))
        ran = round((finished - started).total_seconds(), 1)
    return {**{k: job[k] for k in ("id", "kind", "state", "message", "error")},
            "run_seconds": ran, "wall_seconds": job["wall_seconds"]}


def failures(result: dict, checks: dict, store: dict[str, int] | None) -> list[str]:
    """What did not hold: every job succeeded in a worker container that the broker knows, and with
    an S3 store, the project is in the store and nothing of it is left in the app's containers."""
    found = []
    if [job["state"] for job in result["jobs"]] != ["succeeded", "succeeded"]:
        found.append("a job did not succeed")
    hostnames = set(checks["worker_hostnames"].values())
    if socket.gethostname() in hostnames:
        found.append("a worker container has this machine's hostname: cannot be told apart")
    if not checks["broker_workers"] or any(name.split("@", 1)[1] not in hostnames
                                           for name in checks["broker_workers"]):
        found.append(f"broker workers {checks['broker_workers']} are not all worker containers {hostnames}")
    found += [f"job {job_id} ended in no worker container's log"
              for job_id, container in checks["job_containers"].items() if container is None]
    if store is not None:
        if store.get("images", 0) < result.get("images", 1) or not store.get("versions"):
            found.append(f"the store lacks the project's images or versions: {store}")
        found += [f"{container} keeps {len(files)} files outside the store: {files[:3]}"
                  for container, files in checks["files_left"].items() if files]
    return found


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--url", default=f"http://127.0.0.1:{os.environ.get('GUIDED_SFM_PORT', '8000')}")
    parser.add_argument("--layout", default=None, help="a `guided-sfm sample --layout` (default: its own)")
    args = parser.parse_args()
    started, engine = time.monotonic(), Engine()
    result = rest_loop(Api(args.url), args.layout)
    checks = container_checks(engine, result["jobs"])
    store = store_keys(engine, result["project"])
    problems = failures(result, checks, store)
    summary = {**result, "jobs": [job_summary(job) for job in result["jobs"]], **checks, "store_keys": store,
               "loop_seconds": round(time.monotonic() - started, 1), "failures": problems, "ok": not problems}
    print(json.dumps(summary))
    return 0 if summary["ok"] else 1


if __name__ == "__main__":
    sys.exit(main())
