"""run_job in-process against the real DB (savepoint-isolated): reconstruct, apply, import, failures."""

import json
import shutil

import pycolmap
import pytest

from guided_sfm import jobs
from guided_sfm.actions import runner
from guided_sfm.db.models import Job, Project, Version, Webhook, WebhookDelivery, utcnow
from tests.factories import make_project, make_version, signup, workspace_zip


def upload_dir(client, headers, pid, folder):
    files = [("files", (p.name, p.read_bytes(), "image/jpeg")) for p in sorted(folder.iterdir())]
    response = client.post(f"/api/v1/projects/{pid}/images", files=files, headers=headers)
    assert response.status_code == 201, response.text


def job_json(client, headers, job_id):
    return client.get(f"/api/v1/jobs/{job_id}", headers=headers).json()


def test_reconstruct_job_makes_the_head(client, headers_pid, sessions, settings, submitted, tiny_images):
    headers, pid = headers_pid
    upload_dir(client, headers, pid, tiny_images / "images")
    body = {"matcher": "exhaustive"}
    response = client.post(f"/api/v1/projects/{pid}/reconstruct", json=body, headers=headers)
    assert response.status_code == 202, response.text
    job_id = response.json()["id"]
    assert submitted == [job_id] and response.json()["state"] == "queued"
    assert client.post(f"/api/v1/projects/{pid}/reconstruct", json={}, headers=headers).status_code == 409
    assert runner.run_job(sessions, settings, job_id) == "succeeded"
    job = job_json(client, headers, job_id)
    assert job["state"] == "succeeded" and job["progress"] == 1.0 and job["version_id"]
    assert job["message"].endswith("(exhaustive matching, incremental mapping, max image size 1600)"), \
        job["message"]
    stages = {s["stage"]: s for s in job["timings"]["stages"]}
    assert {"extract", "match", "map"} <= set(stages)
    assert all(s["seconds"] > 0 and s["peak_mb"] > 0 for s in stages.values())
    assert job["timings"]["seconds"] >= sum(s["seconds"] for s in stages.values()) - 0.1
    project = client.get(f"/api/v1/projects/{pid}", headers=headers).json()
    assert project["head_version_id"] == job["version_id"]
    versions = client.get(f"/api/v1/projects/{pid}/versions", headers=headers).json()
    assert versions[0]["stats"]["num_registered"] >= 10 and versions[0]["author"] == "alice"
    assert runner.run_job(sessions, settings, job_id) is None  # a duplicate message is a no-op


def test_jobs_say_what_auto_chose_and_a_reconstruction_reuses_the_projects_tree(
        client, headers_pid, session, sessions, settings, tiny_images):
    headers, pid = headers_pid
    upload_dir(client, headers, pid, tiny_images / "images")
    trees, messages, sizes = [], [], []
    # 0: COLMAP's own size (3200); the tiny sample's 640x480 images get the same features
    for body in ({"matcher": "retrieval"}, {}, {"matcher": "retrieval", "max_image_size": 0}):
        job_id = client.post(f"/api/v1/projects/{pid}/reconstruct", json=body, headers=headers).json()["id"]
        assert runner.run_job(sessions, settings, job_id) == "succeeded"
        job = job_json(client, headers, job_id)
        messages.append(job["message"])
        published = settings.artifacts_dir / session.get(Version, job["version_id"]).path
        tree = published / "vocab_tree.bin"
        trees.append(tree.stat().st_ino if tree.is_file() else None)
        sizes.append(json.loads((published / "workspace.json").read_text())["used"]["max_image_size"])
    assert messages[0].endswith("(retrieval matching, incremental mapping, max image size 1600)"), messages
    assert messages[1].endswith("(auto: exhaustive matching, incremental mapping, max image size 1600)"), \
        messages
    assert messages[2].endswith("(retrieval matching, incremental mapping, max image size 3200)"), messages
    assert sizes == [1600, 1600, 3200]
    # the tree stays with the project: the auto run (12 images: exhaustive) keeps it linked, and
    # the next retrieval run uses the first's rather than training one again
    assert trees[0] is not None and trees == [trees[0]] * 3


@pytest.fixture
def headers_pid(client):
    headers = signup(client, "alice")
    return headers, make_project(client, headers)


def test_failed_job_leaves_head_and_no_files(client, headers_pid, session, sessions, settings,
                                             store_with_version):
    headers, pid = headers_pid
    head = store_with_version(pid)
    pairs = client.get(f"/api/v1/projects/{pid}/versions/{head}/pairs", headers=headers).json()
    edit = {"base_version_id": head, "delete_pairs": [[pairs[0]["image_id1"], pairs[0]["image_id2"]]]}
    eid = client.post(f"/api/v1/projects/{pid}/edits", json=edit, headers=headers).json()["id"]
    job_id = client.post(f"/api/v1/projects/{pid}/edits/{eid}/apply", json={}, headers=headers).json()["id"]
    job = session.get(Job, job_id)
    job.params = {**job.params, "body": {"cameras": [{"image_id": 10**6, "x": 0, "y": 0, "yaw_deg": 0}]}}
    session.commit()
    assert runner.run_job(sessions, settings, job_id) == "failed"
    session.expire_all()
    assert "not part of this version" in session.get(Job, job_id).error
    assert session.get(Job, job_id).stage == "done"
    assert session.get(Job, job_id).timings is not None  # a failed job says where its time went
    assert session.get(Project, pid).head_version_id == head
    assert session.query(Version).filter_by(project_id=pid).count() == 1
    assert not list((settings.artifacts_dir / "projects" / str(pid) / "tmp").iterdir())


def test_apply_without_remap_prunes_into_a_new_head(client, headers_pid, session, sessions, settings,
                                                    store_with_version):
    headers, pid = headers_pid
    head = store_with_version(pid)
    images = client.get(f"/api/v1/projects/{pid}/images", headers=headers).json()
    pairs = client.get(f"/api/v1/projects/{pid}/versions/{head}/pairs", headers=headers).json()
    cut = [pairs[0]["image_id1"], pairs[0]["image_id2"]]
    edit = {"base_version_id": head, "cameras": [], "delete_pairs": [cut]}
    eid = client.post(f"/api/v1/projects/{pid}/edits", json=edit, headers=headers).json()["id"]
    job_id = client.post(f"/api/v1/projects/{pid}/edits/{eid}/apply", json={"remap": False},
                         headers=headers).json()["id"]
    assert runner.run_job(sessions, settings, job_id) == "succeeded"
    job = job_json(client, headers, job_id)
    assert job["stage"] == "done" and job["state"] == "succeeded"  # not "succeeded · succeeded"
    new_url = f"/api/v1/projects/{pid}/versions/{job['version_id']}/pairs"
    new_pairs = client.get(new_url, headers=headers).json()
    assert len(new_pairs) == len(pairs) - 1
    assert cut not in [[p["image_id1"], p["image_id2"]] for p in new_pairs]
    project = client.get(f"/api/v1/projects/{pid}", headers=headers).json()
    assert project["head_version_id"] == job["version_id"]
    assert len(images) == 12


def test_cancel_running_job(client, headers_pid, session, sessions, settings, tiny_images, monkeypatch):
    headers, pid = headers_pid
    upload_dir(client, headers, pid, tiny_images / "images")
    job_id = client.post(f"/api/v1/projects/{pid}/reconstruct", json={}, headers=headers).json()["id"]
    session.get(Job, job_id).cancel_requested = True  # as if the flag was seen by the heartbeat
    session.commit()
    original = runner.JobContext

    class Cancelling(original):
        def __init__(self, *args):
            super().__init__(*args)
            self.cancel.cancel()

    monkeypatch.setattr(runner, "JobContext", Cancelling)
    assert runner.run_job(sessions, settings, job_id) == "cancelled"
    job = job_json(client, headers, job_id)
    assert job["state"] == "cancelled" and job["version_id"] is None
    assert client.get(f"/api/v1/projects/{pid}", headers=headers).json()["head_version_id"] is None


def test_import_job(client, headers_pid, sessions, settings, tiny_reconstruction, tiny_images):
    headers, pid = headers_pid
    archive = workspace_zip(tiny_reconstruction, tiny_images / "images")
    files = {"file": ("ws.zip", archive)}
    response = client.post(f"/api/v1/projects/{pid}/import", files=files, headers=headers)
    assert response.status_code == 202, response.text
    assert runner.run_job(sessions, settings, response.json()["id"]) == "succeeded"
    images = client.get(f"/api/v1/projects/{pid}/images", headers=headers).json()
    assert [i["seq"] for i in images] == list(range(12))
    head = client.get(f"/api/v1/projects/{pid}", headers=headers).json()["head_version_id"]
    scene = client.get(f"/api/v1/projects/{pid}/versions/{head}/scene", headers=headers).json()
    assert {c["image_id"] for c in scene["cameras"]} == {i["id"] for i in images}
    again = client.post(f"/api/v1/projects/{pid}/import", files=files, headers=headers)
    assert again.status_code == 409


def test_an_imported_workspace_numbers_its_models_largest_first_as_reconstruct_does(
        client, headers_pid, session, sessions, settings, tiny_reconstruction, tiny_images, tmp_path):
    from tests.core.test_triage_model_order import _keep_only

    headers, pid = headers_pid
    full = tiny_reconstruction / "sparse" / "0"
    ids = sorted(pycolmap.Reconstruction(full).reg_image_ids())
    few, many = set(ids[-4:]), set(ids[:-4])
    previews = []
    # COLMAP numbers models as it made them: here sparse/0 is the smaller; then the same models in order
    for order in ((few, many), (many, few)):
        workspace = tmp_path / f"ws{len(previews)}"
        (workspace / "sparse").mkdir(parents=True)
        shutil.copy(tiny_reconstruction / "database.db", workspace)
        for index, image_ids in enumerate(order):
            _keep_only(full, image_ids, workspace / "sparse" / str(index))
        project = pid if not previews else make_project(client, headers, "in order")
        files = {"file": ("ws.zip", workspace_zip(workspace, tiny_images / "images"))}
        job_id = client.post(f"/api/v1/projects/{project}/import", files=files, headers=headers).json()["id"]
        assert runner.run_job(sessions, settings, job_id) == "succeeded"
        head = session.get(Project, project).head_version_id
        published = settings.artifacts_dir / session.get(Version, head).path / "sparse"
        assert [pycolmap.Reconstruction(published / k).num_reg_images() for k in ("0", "1")] == [8, 4]
        previews.append(_preview_by_name(client, headers, project, head))
    assert previews[0] == previews[1] and previews[0]["pairs_to_delete"]


def _preview_by_name(client, headers, pid, head):
    """The preview of moving the first camera of the largest model onto the last one, with names."""
    scene = client.get(f"/api/v1/projects/{pid}/versions/{head}/scene", headers=headers).json()
    names = {c["image_id"]: c["name"] for c in scene["cameras"]}
    placed = sorted((c for c in scene["cameras"] if c["registered"]), key=lambda c: c["name"])
    moved = {"image_id": placed[0]["image_id"], "x": placed[-1]["x"], "y": placed[-1]["y"],
             "yaw_deg": placed[-1]["yaw_deg"] + 90}
    edit = {"base_version_id": head, "cameras": [moved]}
    eid = client.post(f"/api/v1/projects/{pid}/edits", json=edit, headers=headers).json()["id"]
    preview = client.get(f"/api/v1/projects/{pid}/edits/{eid}/preview", headers=headers).json()
    return {"pairs_to_delete": sorted(sorted(names[i] for i in pair) for pair in preview["pairs_to_delete"]),
            "reasons": sorted((sorted(names[i] for i in r["pair"]), sorted(r["tests"]))
                              for r in preview["reasons"])}


def test_sweeper_fails_silent_running_jobs_and_resends_lost_ones(client, headers_pid, session, settings):
    from datetime import timedelta

    from worker import sweeper

    headers, pid = headers_pid
    session.add(Webhook(project_id=pid, url="http://a/", events=["job_finished"], secret="s" * 16))
    job_id = client.post(f"/api/v1/projects/{pid}/reconstruct", json={}, headers=headers).json()["id"]
    job = session.get(Job, job_id)
    job.enqueued_at = utcnow() - timedelta(minutes=5)
    session.commit()
    resent = []
    result = sweeper.sweep(_Reusing(session), settings, resent.append)
    assert result == {"requeued": [], "failed": [], "resent": [job_id]} and resent == [job_id]
    for attempt in (1, 2):  # the worker dies twice: re-run once, then failed
        assert jobs.claim(session, job_id)
        session.get(Job, job_id).heartbeat_at = utcnow() - timedelta(minutes=5)
        session.commit()
        result = sweeper.sweep(_Reusing(session), settings, resent.append)
        assert result["requeued" if attempt == 1 else "failed"] == [job_id]
    session.expire_all()
    assert session.get(Job, job_id).state == "failed"
    assert "no heartbeat" in session.get(Job, job_id).error
    told = [json.loads(row.body) for row in session.query(WebhookDelivery)]
    assert [(t["event"], t["data"]["job_id"], t["data"]["state"]) for t in told] == [
        ("job_finished", job_id, "failed")]


class _Reusing:
    """A session factory that hands out the test's session (closing it is harmless)."""

    def __init__(self, session):
        self.session = session

    def __call__(self):
        return self.session


@pytest.fixture
def store_with_version(session, settings, tiny_reconstruction, tiny_images):
    from guided_sfm.storage import ArtifactStore

    def make(pid):
        return make_version(session, ArtifactStore(settings.artifacts_dir), pid, tiny_reconstruction,
                            tiny_images / "images").id

    return make


def test_result_on_a_moved_head_is_kept_as_a_side_version(client, headers_pid, session, settings,
                                                           store_with_version, tiny_reconstruction):
    from guided_sfm.actions.context import Produced
    from guided_sfm.actions.publish import publish
    from guided_sfm.storage import ArtifactStore, link_tree

    headers, pid = headers_pid
    job_id = client.post(f"/api/v1/projects/{pid}/reconstruct", json={}, headers=headers).json()["id"]
    assert jobs.claim(session, job_id)  # based on "no head yet"
    head = store_with_version(pid)  # meanwhile the head moved (as a restore elsewhere would)
    store = ArtifactStore(settings.artifacts_dir)
    with store.staging(pid) as staging:
        link_tree(tiny_reconstruction, staging / "ws")
        produced = Produced(staging / "ws", "reconstruct", "reconstructed", None, {"num_images": 12})
        version = publish(session, store, session.get(Job, job_id), produced)
    session.expire_all()
    assert session.get(Project, pid).head_version_id == head != version.id
    assert "side version" in version.message and "side version" in session.get(Job, job_id).message
    assert session.get(Job, job_id).state == "succeeded" and session.get(Job, job_id).version_id == version.id
