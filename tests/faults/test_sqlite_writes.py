"""Concurrent writes through a real API process never fail with "database is locked": a save race
has one winner and 409s, and uploads and saves go through while a worker writes its job row."""

from __future__ import annotations

import subprocess
import sys
import threading
import uuid

from guided_sfm.db.models import Job, Version
from guided_sfm.db.session import make_engine, make_sessionmaker
from tests.factories import jpeg_bytes
from tests.faults.conftest import login


def _project_with_version_and_job(api, headers) -> tuple[int, int, int]:
    """A project with a version row (no files: edit sets only look the row up) and a running job."""
    status, project, _ = api.request("POST", "/api/v1/projects", {"name": "race"}, headers)
    assert status == 201, project
    sessions = make_sessionmaker(make_engine(api.database_url))
    with sessions() as session:
        version = Version(project_id=project["id"], kind="reconstruct", path="none", stats={})
        session.add(version)
        session.flush()
        job = Job(project_id=project["id"], kind="reconstruct", state="running", stage="map",
                  params={}, attempts=1)
        session.add(job)
        session.commit()
        ids = project["id"], version.id, job.id
    sessions.kw["bind"].dispose()
    return ids


def _at_once(calls) -> list:
    """Run the callables in threads released together; their results in order."""
    results, gate = [None] * len(calls), threading.Barrier(len(calls))

    def run(index, call):
        gate.wait()
        results[index] = call()

    threads = [threading.Thread(target=run, args=(i, c)) for i, c in enumerate(calls)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=120)
    return results


def _multipart(name: str, data: bytes) -> tuple[bytes, dict[str, str]]:
    boundary = uuid.uuid4().hex
    body = (f"--{boundary}\r\nContent-Disposition: form-data; name=\"files\"; filename=\"{name}\"\r\n"
            f"Content-Type: image/jpeg\r\n\r\n").encode() + data + f"\r\n--{boundary}--\r\n".encode()
    return body, {"Content-Type": f"multipart/form-data; boundary={boundary}"}


def test_save_race_and_writes_during_a_job(live_factory):
    api = live_factory()
    headers = login(api, "racer")
    pid, vid, job_id = _project_with_version_and_job(api, headers)
    beat = subprocess.Popen([sys.executable, "-m", "tests.faults.beat_writer", api.database_url,
                             str(job_id), "30"], stdout=subprocess.PIPE, text=True, env=api.env)
    try:
        assert beat.stdout.readline().strip() == "writing"
        body = {"base_version_id": vid, "cameras": []}
        status, edit, _ = api.request("POST", f"/api/v1/projects/{pid}/edits", body, headers)
        assert status == 201, edit
        put = f"/api/v1/projects/{pid}/edits/{edit['id']}"
        saves = _at_once([lambda: api.request("PUT", put, body, {**headers, "If-Match": "1"})[:2]] * 20)
        codes = sorted(code for code, _ in saves)
        assert codes == [200] + [409] * 19, saves
        uploads = [_multipart(f"img{i}.jpg", jpeg_bytes(color=(i, 40, 90))) for i in range(8)]
        calls = [lambda d=d, h=h: api.request("POST", f"/api/v1/projects/{pid}/images", data=d,
                                              headers={**headers, **h})[:2] for d, h in uploads]
        calls += [lambda: api.request("POST", f"/api/v1/projects/{pid}/edits", body, headers)[:2]] * 8
        results = _at_once(calls)
        assert [code for code, _ in results] == [201] * 16, results
    finally:
        beat.terminate()
        writes = beat.communicate(timeout=30)[0]
    assert int(writes) > 20, "the worker-like writer must have written during the requests"
