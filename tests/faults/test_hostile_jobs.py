"""Jobs under hostile input, with a real worker process: an imported database.db whose `images` is a
view over an endless recursive query fails at once; a job past its time limit fails with a message;
the worker then runs the next job."""

from __future__ import annotations

import sqlite3

from tests.factories import jpeg_bytes, make_project, signup, zip_bytes
from tests.worker.live import upload

ENDLESS = ("WITH RECURSIVE r(x) AS (SELECT 1 UNION ALL SELECT x + 1 FROM r) "
           "SELECT 1 AS image_id, 'a.jpg' AS name, 1 AS camera_id FROM r")


def hostile_database(path) -> bytes:
    conn = sqlite3.connect(path)
    for table in ("cameras", "keypoints", "descriptors", "matches", "two_view_geometries"):
        conn.execute(f"CREATE TABLE {table} (id INTEGER PRIMARY KEY)")
    conn.execute(f"CREATE VIEW images AS {ENDLESS}")
    conn.commit()
    conn.close()
    return path.read_bytes()


def _job(service, headers, pid, route, **kwargs) -> int:
    response = service.client.post(f"/api/v1/projects/{pid}/{route}", headers=headers, **kwargs)
    assert response.status_code == 202, response.text
    return response.json()["id"]


def _ended(job) -> bool:
    return job["state"] in ("succeeded", "failed", "cancelled")


def test_hostile_import_and_time_limit_then_the_next_job_runs(service_factory, tmp_path, tiny_images):
    service = service_factory("filesystem://", job_base_seconds=1, job_seconds_per_image=0,
                              heartbeat_seconds=0.5)
    service.start_worker()
    headers = signup(service.client, "mallory")
    archive = zip_bytes({"database.db": hostile_database(tmp_path / "hostile.db"),
                         "sparse/0/cameras.bin": b"\0" * 8, "images/a.jpg": jpeg_bytes()})
    hostile = _job(service, headers, make_project(service.client, headers, "hostile"), "import",
                   files={"file": ("ws.zip", archive, "application/zip")})
    job = service.wait_job(headers, hostile, _ended, timeout=90)
    assert job["state"] == "failed" and "view images" in job["error"], job
    slow_pid = make_project(service.client, headers, "slow")
    upload(service, headers, slow_pid, tiny_images / "images")
    slow = service.wait_job(headers, _job(service, headers, slow_pid, "reconstruct", json={}), _ended, 90)
    assert slow["state"] == "failed" and "time limit of 1 s" in slow["error"], slow
    empty = _job(service, headers, make_project(service.client, headers, "next"), "reconstruct", json={})
    job = service.wait_job(headers, empty, _ended, timeout=60)
    assert job["state"] == "failed" and "at least 2 images" in job["error"], job
