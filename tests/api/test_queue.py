"""The queue's order (jobs.QUEUE_ORDER) and queue_position: applies first, then by arrival."""

from guided_sfm import jobs
from guided_sfm.actions import runner
from guided_sfm.db.models import Job
from tests.factories import make_project


def test_applies_go_first_then_first_come(client, session, reconstructed, sessions, settings):
    s = reconstructed
    others = [make_project(client, s.owner, name) for name in ("a", "b")]
    for pid in others:
        session.add(Job(project_id=pid, kind="reconstruct", state="queued", params={}))
        session.commit()
    pair = client.get(f"/api/v1/projects/{s.pid}/versions/{s.vid}/pairs", headers=s.owner).json()[0]
    body = {"base_version_id": s.vid, "delete_pairs": [[pair["image_id1"], pair["image_id2"]]]}
    eid = client.post(f"/api/v1/projects/{s.pid}/edits", json=body, headers=s.owner).json()["id"]
    applied = client.post(f"/api/v1/projects/{s.pid}/edits/{eid}/apply", json={"remap": False},
                          headers=s.owner).json()
    assert applied["queue_position"] == 1
    listed = {p: client.get(f"/api/v1/projects/{p}/jobs", headers=s.owner).json()[0]["queue_position"]
              for p in others}
    assert listed == {others[0]: 2, others[1]: 3}
    reconstruct_a = client.get(f"/api/v1/projects/{others[0]}/jobs", headers=s.owner).json()[0]["id"]
    # the message of the first reconstruction wakes the worker; the apply runs
    assert runner.run_job(sessions, settings, reconstruct_a) == "succeeded"
    ran = client.get(f"/api/v1/jobs/{applied['id']}", headers=s.owner).json()
    assert ran["state"] == "succeeded" and ran["queue_position"] is None
    assert client.get(f"/api/v1/jobs/{reconstruct_a}", headers=s.owner).json()["queue_position"] == 1
    assert jobs.queued_in_order(session) == [reconstruct_a, reconstruct_a + 1]


def test_a_message_with_nothing_queued_runs_nothing(sessions, settings):
    assert runner.run_job(sessions, settings, 12345) is None
