"""Jobs over REST: queue, one active job per project, cancel, list."""

from guided_sfm.db.models import Job
from tests.factories import jpeg_bytes, make_project, signup


def setup_project(client):
    headers = signup(client, "alice")
    pid = make_project(client, headers)
    files = [("files", (f"{i}.jpg", jpeg_bytes(color=(i, 0, 0)), "image/jpeg")) for i in range(2)]
    client.post(f"/api/v1/projects/{pid}/images", files=files, headers=headers)
    return headers, pid


def test_queue_then_409_then_cancel(client, submitted, session):
    headers, pid = setup_project(client)
    body = {"camera_model": "PINHOLE", "matcher": "sequential", "mapper": "global"}
    response = client.post(f"/api/v1/projects/{pid}/reconstruct", json=body, headers=headers)
    assert response.status_code == 202, response.text
    job = response.json()
    fields = {"id", "project_id", "kind", "state", "stage", "progress", "message", "error", "version_id",
              "created_at", "started_at", "finished_at"}
    assert fields <= set(job) and job["kind"] == "reconstruct" and job["state"] == "queued"
    assert submitted == [job["id"]] and session.get(Job, job["id"]).params == body
    again = client.post(f"/api/v1/projects/{pid}/reconstruct", json={}, headers=headers)
    assert again.status_code == 409 and "queued or running" in again.json()["detail"]
    cancelled = client.post(f"/api/v1/jobs/{job['id']}/cancel", headers=headers).json()
    assert cancelled["state"] == "cancelled" and cancelled["finished_at"] and cancelled["stage"] == "done"
    assert client.post(f"/api/v1/jobs/{job['id']}/cancel", headers=headers).status_code == 409
    listed = client.get(f"/api/v1/projects/{pid}/jobs", headers=headers).json()
    assert [j["id"] for j in listed] == [job["id"]]


def test_cancel_running_sets_the_flag(client, session):
    from guided_sfm import jobs

    headers, pid = setup_project(client)
    job_id = client.post(f"/api/v1/projects/{pid}/reconstruct", json={}, headers=headers).json()["id"]
    assert jobs.claim(session, job_id)
    response = client.post(f"/api/v1/jobs/{job_id}/cancel", headers=headers).json()
    assert response["state"] == "running" and response["cancel_requested"] is True


def test_bad_options_are_422_and_no_job(client, session):
    headers, pid = setup_project(client)
    for body in ({"matcher": "vocab"}, {"camera_model": "FISHEYE_42"}, {"mapper": 3}):
        response = client.post(f"/api/v1/projects/{pid}/reconstruct", json=body, headers=headers)
        assert response.status_code == 422, body
        assert response.json()["detail"]
    assert session.query(Job).count() == 0


def test_a_max_image_size_outside_0_or_256_to_10000_is_422_naming_it_and_no_job(client, session):
    headers, pid = setup_project(client)
    for size in (-1, 1, 255, 10001, "1600", 1600.5, True):
        body = {"max_image_size": size}
        response = client.post(f"/api/v1/projects/{pid}/reconstruct", json=body, headers=headers)
        assert response.status_code == 422, body
        assert "max_image_size" in response.json()["detail"], response.text
    assert session.query(Job).count() == 0


def test_a_max_image_size_is_kept_with_the_job(client, session):
    headers, pid = setup_project(client)
    for size in (0, 256, 10000):
        body = {"matcher": "exhaustive", "max_image_size": size}
        response = client.post(f"/api/v1/projects/{pid}/reconstruct", json=body, headers=headers)
        assert response.status_code == 202, response.text
        assert session.get(Job, response.json()["id"]).params == body
        client.post(f"/api/v1/jobs/{response.json()['id']}/cancel", headers=headers)


def test_enqueue_failure_keeps_the_committed_job(client, session):
    client.app.state.submit = lambda job_id: (_ for _ in ()).throw(ConnectionError("broker down"))
    headers, pid = setup_project(client)
    response = client.post(f"/api/v1/projects/{pid}/reconstruct", json={}, headers=headers)
    assert response.status_code == 202  # the sweeper will resend it
    assert session.get(Job, response.json()["id"]).state == "queued"


def test_import_refuses_bad_zips_and_non_empty_projects(client, session):
    from tests.factories import zip_bytes

    headers = signup(client, "alice")
    pid = make_project(client, headers)
    cases = [(b"not a zip", "zip"), (zip_bytes({"x.txt": b"1"}), "database.db"),
             (zip_bytes({"../database.db": b"1"}), "'..'")]
    for data, words in cases:
        files = {"file": ("w.zip", data)}
        response = client.post(f"/api/v1/projects/{pid}/import", files=files, headers=headers)
        assert response.status_code == 422 and words in response.json()["detail"], response.text
    assert session.query(Job).count() == 0
    files = [("files", ("a.jpg", jpeg_bytes(), "image/jpeg"))]
    client.post(f"/api/v1/projects/{pid}/images", files=files, headers=headers)
    full = client.post(f"/api/v1/projects/{pid}/import", files={"file": ("w.zip", b"PK")}, headers=headers)
    assert full.status_code == 409 and "empty" in full.json()["detail"]


def test_unknown_job_is_404(client):
    headers = signup(client, "alice")
    assert client.get("/api/v1/jobs/424242", headers=headers).status_code == 404
