"""The paper's loop through the REST contract only, with a real worker: sign up, upload the rendered
sample, reconstruct, read the scene, move the wrong cameras near their true poses, preview, apply
with remap, poll, and check the new version's cameras against the sample's ground truth."""

from __future__ import annotations

import numpy as np
import pytest

from guided_sfm.core import metrics, simulated_user
from guided_sfm.core.geometry import rotation_from_qvec
from guided_sfm.core.truth import Truth, load_truth
from guided_sfm.core.types import TopDownScene
from tests.factories import make_project, signup
from tests.worker.live import upload

JOB_TIMEOUT = 1800.0  # 52 images matched exhaustively on 2 cores


def poses(scene: dict) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    return {c["name"]: (rotation_from_qvec(c["qvec"]), np.asarray(c["center"], float))
            for c in scene["cameras"] if c["registered"] and c["center"] is not None}


def status(scene: dict, truth: Truth, reference: list[str] | None = None):
    """(wrong names, unregistered names, truth_from_model) after aligning on the reference cameras."""
    found = poses(scene)
    names = sorted(n for n in (reference or found) if n in found)
    sim = metrics.align_similarity(np.array([found[n][1] for n in names]),
                                   np.array([truth.cameras[n].center for n in names]))
    true_poses = {n: (c.rotation, c.center) for n, c in truth.cameras.items()}
    errors = metrics.camera_errors(found, true_poses, sim)
    wrong = sorted(n for n, bad in metrics.classify(errors).items() if bad)
    unregistered = sorted(c["name"] for c in scene["cameras"] if c["name"] not in found)
    return wrong, unregistered, sim


def finished(service, headers, job: dict) -> dict:
    def ended(j: dict) -> bool:
        return j["state"] not in ("queued", "running")

    done = service.wait_job(headers, job["id"], ended, JOB_TIMEOUT)
    assert done["state"] == "succeeded", f"job {done['id']} ({done['kind']}) {done['state']}: {done['error']}"
    return done


@pytest.mark.slow
def test_rest_loop_fixes_the_wrong_cameras(service_factory, murals_images):
    service = service_factory("filesystem://")
    service.start_worker()
    client, headers = service.client, signup(service.client, "alice")
    truth = load_truth(murals_images / "truth.json")
    pid = make_project(client, headers, "murals")
    upload(service, headers, pid, murals_images / "images")
    first = finished(service, headers, client.post(f"/api/v1/projects/{pid}/reconstruct", json={},
                                                   headers=headers).json())
    base = first["version_id"]
    scene = client.get(f"/api/v1/projects/{pid}/versions/{base}/scene", headers=headers).json()
    wrong, unregistered, sim = status(scene, truth)
    targets = [n for n in wrong + unregistered if n in truth.cameras]
    assert targets, "the sample is meant to fold some cameras wrongly"
    right_before = sorted(set(poses(scene)) - set(wrong))

    edits = simulated_user.place_cameras(TopDownScene.from_dict(scene), truth, targets, sim, seed=1)
    body = {"base_version_id": base, "rule": "default",
            "cameras": [{"image_id": e.image_id, "x": e.x, "y": e.y, "yaw_deg": e.yaw_deg} for e in edits]}
    created = client.post(f"/api/v1/projects/{pid}/edits", json=body, headers=headers)
    assert created.status_code == 201, created.text
    eid = created.json()["id"]
    preview = client.get(f"/api/v1/projects/{pid}/edits/{eid}/preview", headers=headers).json()
    assert preview["pairs_to_delete"], preview
    applied = client.post(f"/api/v1/projects/{pid}/edits/{eid}/apply", json={"remap": True}, headers=headers)
    assert applied.status_code == 202, applied.text
    done = finished(service, headers, applied.json())

    project = client.get(f"/api/v1/projects/{pid}", headers=headers).json()
    assert project["head_version_id"] == done["version_id"]
    new_url = f"/api/v1/projects/{pid}/versions/{done['version_id']}/scene"
    new_scene = client.get(new_url, headers=headers).json()
    wrong_after, unregistered_after, _ = status(new_scene, truth, reference=right_before)
    still_wrong = set(targets) & set(wrong_after + unregistered_after)
    assert not still_wrong, f"targets {targets}: still wrong or unregistered {sorted(still_wrong)}"
    assert not wrong_after, f"cameras wrong after the round: {wrong_after}"
