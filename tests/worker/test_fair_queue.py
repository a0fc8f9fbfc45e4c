"""The queue's order with one real worker busy on a long reconstruction of project A: an apply of
project C queued after a reconstruction of project B starts before it; queue_position shows the
order as it changes."""

import time

import pytest

from guided_sfm.storage import ArtifactStore
from tests.factories import make_project, make_version, signup
from tests.worker.live import upload

ENDED = ("succeeded", "failed", "cancelled")


def apply_job(service, headers, tiny_images, tiny_reconstruction) -> tuple[int, int]:
    """A project with a version and an edit set that deletes one pair: (project id, edit set id)."""
    client = service.client
    pid = make_project(client, headers, "edited")
    with service.sessions() as session:
        vid = make_version(session, ArtifactStore(service.settings.artifacts_dir), pid, tiny_reconstruction,
                           tiny_images / "images").id
        session.commit()
    pair = client.get(f"/api/v1/projects/{pid}/versions/{vid}/pairs", headers=headers).json()[0]
    body = {"base_version_id": vid, "delete_pairs": [[pair["image_id1"], pair["image_id2"]]]}
    return pid, client.post(f"/api/v1/projects/{pid}/edits", json=body, headers=headers).json()["id"]


@pytest.mark.slow
def test_an_apply_overtakes_a_reconstruction_queued_before_it(service_factory, tiny_images,
                                                              tiny_reconstruction, murals_images):
    service = service_factory("filesystem://")
    client, headers = service.client, signup(service.client, "ann")
    job = lambda j: client.get(f"/api/v1/jobs/{j['id']}", headers=headers).json()  # noqa: E731
    long_pid, short_pid = make_project(client, headers, "long"), make_project(client, headers, "short")
    upload(service, headers, long_pid, murals_images / "images")
    upload(service, headers, short_pid, tiny_images / "images")
    edited, eid = apply_job(service, headers, tiny_images, tiny_reconstruction)
    service.start_worker()
    long = client.post(f"/api/v1/projects/{long_pid}/reconstruct", json={}, headers=headers).json()
    service.wait_job(headers, long["id"], lambda j: j["state"] == "running", 120)
    short = client.post(f"/api/v1/projects/{short_pid}/reconstruct", json={}, headers=headers).json()
    apply = client.post(f"/api/v1/projects/{edited}/edits/{eid}/apply", json={"remap": False},
                        headers=headers).json()
    seen = []  # (long's state, short's position, apply's position) each time it changes
    while True:
        now = [job(long), job(short), job(apply)]
        row = (now[0]["state"], now[1]["queue_position"], now[2]["queue_position"])
        if not seen or seen[-1] != row:
            seen.append(row)
        if all(j["state"] in ENDED for j in now):
            break
        time.sleep(0.3)
    print("queue as it changed (long's state, short's position, apply's position):", seen)
    assert [j["state"] for j in now] == ["succeeded"] * 3, now
    assert seen[0] == ("running", 2, 1)
    assert now[2]["finished_at"] <= now[1]["started_at"]
    assert now[0]["finished_at"] <= now[2]["started_at"]  # one worker: nothing was interrupted
