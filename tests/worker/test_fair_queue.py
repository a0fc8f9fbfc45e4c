"""The queue's order with one real worker: an apply queued after two reconstructions of other
projects runs first; queue_position says so while they wait."""

from guided_sfm.storage import ArtifactStore
from tests.factories import make_project, make_version, signup
from tests.worker.live import upload

ENDED = ("succeeded", "failed", "cancelled")


def test_an_apply_overtakes_reconstructions_queued_before_it(service_factory, tiny_images,
                                                              tiny_reconstruction):
    service = service_factory("filesystem://")
    client, headers = service.client, signup(service.client, "ann")
    queued = []
    for name in ("first", "second"):
        pid = make_project(client, headers, name)
        upload(service, headers, pid, tiny_images / "images")
        queued.append(client.post(f"/api/v1/projects/{pid}/reconstruct", json={}, headers=headers).json())
    pid = make_project(client, headers, "edited")
    with service.sessions() as session:
        vid = make_version(session, ArtifactStore(service.settings.artifacts_dir), pid, tiny_reconstruction,
                           tiny_images / "images").id
        session.commit()
    pair = client.get(f"/api/v1/projects/{pid}/versions/{vid}/pairs", headers=headers).json()[0]
    body = {"base_version_id": vid, "delete_pairs": [[pair["image_id1"], pair["image_id2"]]]}
    eid = client.post(f"/api/v1/projects/{pid}/edits", json=body, headers=headers).json()["id"]
    queued.append(client.post(f"/api/v1/projects/{pid}/edits/{eid}/apply", json={"remap": False},
                              headers=headers).json())
    positions = [client.get(f"/api/v1/jobs/{j['id']}", headers=headers).json()["queue_position"]
                 for j in queued]
    assert positions == [2, 3, 1]
    service.start_worker()
    done = [service.wait_job(headers, j["id"], lambda job: job["state"] in ENDED, 600) for j in queued]
    assert [j["state"] for j in done] == ["succeeded"] * 3, done
    assert all(j["queue_position"] is None for j in done)
    first, second, apply = done
    assert apply["finished_at"] <= first["started_at"] <= second["started_at"]
    print(f"apply ran {apply['started_at']}..{apply['finished_at']}, reconstructions from "
          f"{first['started_at']} and {second['started_at']}")
