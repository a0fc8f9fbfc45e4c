"""The sweeper leaves live jobs alone and resends a lost message once; publish is all or nothing
when the job was ended by someone else while it ran."""

from datetime import timedelta

import pytest

from guided_sfm import jobs
from guided_sfm.actions.context import Produced
from guided_sfm.actions.publish import publish
from guided_sfm.db.models import Job, Project, Version, utcnow
from guided_sfm.errors import Conflict
from guided_sfm.storage import ArtifactStore, link_tree
from tests.factories import make_project, signup
from tests.worker.test_runner import _Reusing
from worker import sweeper


@pytest.fixture
def headers_pid(client):
    headers = signup(client, "alice")
    return headers, make_project(client, headers)


def queue_job(client, headers, pid) -> int:
    response = client.post(f"/api/v1/projects/{pid}/reconstruct", json={}, headers=headers)
    assert response.status_code == 202, response.text
    return response.json()["id"]


def test_a_live_running_job_and_a_fresh_queued_one_are_left_alone(client, headers_pid, session, settings):
    headers, pid = headers_pid
    running = queue_job(client, headers, pid)
    assert jobs.claim(session, running)  # its heartbeat is now
    other = client.post("/api/v1/projects", json={"name": "q"}, headers=headers).json()["id"]
    queued = queue_job(client, headers, other)  # enqueued now
    resent = []
    assert sweeper.sweep(_Reusing(session), settings, resent.append) == {
        "requeued": [], "failed": [], "resent": []}
    session.expire_all()
    assert session.get(Job, running).state == "running" and session.get(Job, queued).state == "queued"
    assert resent == []


def test_a_lost_message_is_resent_once_per_requeue_period(client, headers_pid, session, settings):
    headers, pid = headers_pid
    job_id = queue_job(client, headers, pid)
    session.get(Job, job_id).enqueued_at = utcnow() - timedelta(seconds=settings.requeue_seconds + 60)
    session.commit()
    resent = []
    for _ in range(3):  # sweeps in quick succession: the first resends, the rest wait their turn
        sweeper.sweep(_Reusing(session), settings, resent.append)
    assert resent == [job_id]


def test_publish_after_someone_ended_the_job_writes_nothing(client, headers_pid, session, settings,
                                                            tiny_reconstruction):
    headers, pid = headers_pid
    job_id = queue_job(client, headers, pid)
    assert jobs.claim(session, job_id)
    jobs.finish(session, job_id, "failed", error="the sweeper gave up on it")  # while it ran
    session.commit()
    store = ArtifactStore(settings.artifacts_dir)
    with store.staging(pid) as staging:
        link_tree(tiny_reconstruction, staging / "ws")
        produced = Produced(staging / "ws", "reconstruct", "reconstructed", None, {"num_images": 12})
        with pytest.raises(Conflict, match="ended by someone else"):
            publish(session, store, session.get(Job, job_id), produced)
    session.expire_all()
    assert session.get(Project, pid).head_version_id is None
    assert session.query(Version).filter_by(project_id=pid).count() == 0
    assert session.get(Job, job_id).state == "failed" and session.get(Job, job_id).version_id is None
    versions = store.project_dir(pid) / "versions"
    assert not versions.exists() or list(versions.iterdir()) == []  # the renamed workspace is discarded
