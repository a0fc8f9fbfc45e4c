"""Edit sets: validation at the edge (nothing stored on 4xx), optimistic concurrency, preview, apply."""

import json
import math

import pytest

from guided_sfm.db.models import EditSetRow, Job


def url(s, suffix=""):
    return f"/api/v1/projects/{s.pid}/edits{suffix}"


def camera(image_id, **extra):
    return {"image_id": image_id, "x": 0.5, "y": -0.25, "yaw_deg": 30.0, **extra}


def first_id(s):
    return s.image_ids[sorted(s.image_ids)[0]]


def test_create_read_list_delete(client, reconstructed):
    s = reconstructed
    body = {"base_version_id": s.vid, "cameras": [camera(first_id(s), fov_deg=60, range=2)],
            "flags": [first_id(s)], "rule": "paper"}
    created = client.post(url(s), json=body, headers=s.owner)
    assert created.status_code == 201, created.text
    data = created.json()
    assert data["revision"] == 1 and created.headers["ETag"] == '"1"'
    assert data["cameras"][0]["fov_deg"] == 60 and data["updated_by"] == "owner" and data["rule"] == "paper"
    assert client.get(url(s, f"/{data['id']}"), headers=s.owner).json()["cameras"] == data["cameras"]
    assert [e["id"] for e in client.get(url(s), headers=s.owner).json()] == [data["id"]]
    assert client.delete(url(s, f"/{data['id']}"), headers=s.owner).status_code == 204
    assert client.get(url(s, f"/{data['id']}"), headers=s.owner).status_code == 404


def bad_bodies(s):
    good = first_id(s)
    return {
        "nan x": ({"base_version_id": s.vid, "cameras": [camera(good, x=math.nan)]}, "x"),
        "inf yaw": ({"base_version_id": s.vid, "cameras": [camera(good, yaw_deg=math.inf)]}, "yaw_deg"),
        "fov 0": ({"base_version_id": s.vid, "cameras": [camera(good, fov_deg=0)]}, "fov_deg"),
        "fov 180": ({"base_version_id": s.vid, "cameras": [camera(good, fov_deg=180)]}, "fov_deg"),
        "range 0": ({"base_version_id": s.vid, "cameras": [camera(good, range=0)]}, "range"),
        "range -1": ({"base_version_id": s.vid, "cameras": [camera(good, range=-1)]}, "range"),
        "unknown image": ({"base_version_id": s.vid, "cameras": [camera(99999)]}, "unknown image id 99999"),
        "unknown pair image": ({"base_version_id": s.vid, "delete_pairs": [[good, 99999]]}, "99999"),
        "self pair": ({"base_version_id": s.vid, "delete_pairs": [[good, good]]}, "two different"),
        "unknown flag": ({"base_version_id": s.vid, "flags": [99999]}, "flags"),
        "camera twice": ({"base_version_id": s.vid, "cameras": [camera(good), camera(good)]}, "twice"),
        "foreign version": ({"base_version_id": 99999}, "version 99999"),
        "bad rule": ({"base_version_id": s.vid, "rule": "magic"}, "rule"),
        "string id": ({"base_version_id": s.vid, "cameras": [camera("1")]}, "image_id"),
        "extra field": ({"base_version_id": s.vid, "colour": "red"}, "colour"),
    }


CASES = ["nan x", "inf yaw", "fov 0", "fov 180", "range 0", "range -1", "unknown image",
         "unknown pair image", "self pair", "unknown flag", "camera twice", "foreign version", "bad rule",
         "string id", "extra field"]


@pytest.mark.parametrize("case", CASES)
def test_bad_edit_set_is_4xx_and_nothing_stored(client, reconstructed, session, case):
    s = reconstructed
    body, words = bad_bodies(s)[case]
    raw = json.dumps(body)  # NaN and Infinity as JS literals, as a browser could send them
    response = client.post(url(s), content=raw, headers={**s.owner, "Content-Type": "application/json"})
    assert response.status_code in (404, 422), response.text
    assert words in response.json()["detail"]
    assert session.query(EditSetRow).count() == 0


def test_nan_as_json_literal_is_422(client, reconstructed):
    s = reconstructed
    camera_ = f'{{"image_id": {first_id(s)}, "x": NaN, "y": 0, "yaw_deg": 0}}'
    raw = f'{{"base_version_id": {s.vid}, "cameras": [{camera_}]}}'
    response = client.post(url(s), content=raw, headers={**s.owner, "Content-Type": "application/json"})
    assert response.status_code == 422


def test_version_of_another_project_is_refused(client, reconstructed, session, store, tiny_reconstruction,
                                              tiny_images):
    from tests.factories import make_project, make_version

    s = reconstructed
    other = make_project(client, s.owner, "other")
    foreign = make_version(session, store, other, tiny_reconstruction, tiny_images / "images")
    response = client.post(url(s), json={"base_version_id": foreign.id}, headers=s.owner)
    assert response.status_code == 404 and f"version {foreign.id}" in response.json()["detail"]


def test_same_revision_twice_one_wins_one_409(client, reconstructed):
    s = reconstructed
    created = client.post(url(s), json={"base_version_id": s.vid}, headers=s.owner).json()
    mine = {"base_version_id": s.vid, "cameras": [camera(first_id(s), x=1.0)]}
    theirs = {"base_version_id": s.vid, "cameras": [camera(first_id(s), x=2.0)]}
    first = client.put(url(s, f"/{created['id']}"), json=mine, headers={**s.owner, "If-Match": "1"})
    second = client.put(url(s, f"/{created['id']}"), json=theirs, headers={**s.owner, "If-Match": '"1"'})
    assert first.status_code == 200 and first.json()["revision"] == 2 and first.headers["ETag"] == '"2"'
    assert second.status_code == 409 and "revision 1" in second.json()["detail"]
    saved = client.get(url(s, f"/{created['id']}"), headers=s.owner).json()
    assert saved["cameras"][0]["x"] == 1.0 and saved["revision"] == 2  # the winner's save is intact
    third = client.put(url(s, f"/{created['id']}"), json=theirs, headers={**s.owner, "If-Match": 'W/"2"'})
    assert third.status_code == 200 and third.json()["revision"] == 3


def test_put_without_if_match_is_428_and_garbage_is_409(client, reconstructed):
    s = reconstructed
    created = client.post(url(s), json={"base_version_id": s.vid}, headers=s.owner).json()
    body = {"base_version_id": s.vid}
    assert client.put(url(s, f"/{created['id']}"), json=body, headers=s.owner).status_code == 428
    response = client.put(url(s, f"/{created['id']}"), json=body, headers={**s.owner, "If-Match": "abc"})
    assert response.status_code == 409


def test_preview_lists_pairs_in_rest_ids(client, reconstructed):
    s = reconstructed
    pairs = client.get(f"/api/v1/projects/{s.pid}/versions/{s.vid}/pairs", headers=s.owner).json()
    cut = [pairs[0]["image_id1"], pairs[0]["image_id2"]]
    scene = client.get(f"/api/v1/projects/{s.pid}/versions/{s.vid}/scene", headers=s.owner).json()
    cam = next(c for c in scene["cameras"] if c["registered"])
    moved = {"image_id": cam["image_id"], "x": cam["x"] + 50.0, "y": cam["y"] + 50.0, "yaw_deg": 0.0}
    body = {"base_version_id": s.vid, "cameras": [moved], "delete_pairs": [cut], "rule": "paper"}
    eid = client.post(url(s), json=body, headers=s.owner).json()["id"]
    preview = client.get(url(s, f"/{eid}/preview"), headers=s.owner)
    assert preview.status_code == 200, preview.text
    data = preview.json()
    assert cut in data["pairs_to_delete"]
    ids = set(s.image_ids.values())
    assert all(a in ids and b in ids and a < b for a, b in data["pairs_to_delete"])
    moved_pairs = [p for p in data["pairs_to_delete"] if cam["image_id"] in p]
    assert len(moved_pairs) >= 1  # a camera thrown 50 units away sees none of its partners
    assert data["components_before"] >= 1 and sum(data["removed_by_test"].values()) >= len(moved_pairs)
    assert {tuple(r["pair"]) for r in data["reasons"]} == {tuple(p) for p in data["pairs_to_delete"]}
    assert data["kept_to_connect"] == []  # the paper's rule keeps nothing


def a_pair(client, s):
    pairs = client.get(f"/api/v1/projects/{s.pid}/versions/{s.vid}/pairs", headers=s.owner).json()
    return [pairs[0]["image_id1"], pairs[0]["image_id2"]]


def test_an_empty_apply_is_422_nothing_to_apply_and_makes_no_job(client, reconstructed, submitted, session):
    from guided_sfm.db.models import Version

    s = reconstructed
    flagged = {"base_version_id": s.vid, "flags": [first_id(s)]}  # a flag alone changes nothing either
    for body in ({"base_version_id": s.vid}, {"base_version_id": s.vid, "cameras": []}, flagged):
        eid = client.post(url(s), json=body, headers=s.owner).json()["id"]
        response = client.post(url(s, f"/{eid}/apply"), json={"remap": True}, headers=s.owner)
        assert response.status_code == 422 and "nothing to apply" in response.json()["detail"], response.text
    assert session.query(Job).count() == 0 and submitted == []
    assert session.query(Version).filter_by(project_id=s.pid).count() == 1


def test_apply_queues_a_job_and_refuses_a_stale_base(client, reconstructed, submitted, session):
    from guided_sfm.db.models import Project

    s = reconstructed
    body = {"base_version_id": s.vid, "delete_pairs": [a_pair(client, s)]}
    eid = client.post(url(s), json=body, headers=s.owner).json()["id"]
    response = client.post(url(s, f"/{eid}/apply"), json={"remap": True}, headers=s.owner)
    assert response.status_code == 202, response.text
    job = response.json()
    assert job["kind"] == "apply" and job["state"] == "queued" and submitted == [job["id"]]
    assert session.get(Job, job["id"]).params["remap"] is True
    assert client.post(url(s, f"/{eid}/apply"), json={}, headers=s.owner).status_code == 409  # job active
    client.post(f"/api/v1/jobs/{job['id']}/cancel", headers=s.owner)
    session.get(Project, s.pid).head_version_id = None  # the head moved away from the edit's base
    session.commit()
    stale = client.post(url(s, f"/{eid}/apply"), json={}, headers=s.owner)
    assert stale.status_code == 409 and "head" in stale.json()["detail"]


def test_an_edit_set_without_a_rule_gets_the_default_rule(client, reconstructed):
    s = reconstructed
    created = client.post(url(s), json={"base_version_id": s.vid}, headers=s.owner)
    assert created.status_code == 201 and created.json()["rule"] == "default"
    schema = client.get("/openapi.json").json()["components"]["schemas"]["EditSetIn"]
    assert schema["properties"]["rule"]["enum"] == ["default", "paper"]
    assert schema["properties"]["rule"]["default"] == "default"


def test_rebase_carries_a_stale_edit_set_onto_the_head_and_reports_what_it_dropped(
        client, reconstructed, session, sessions, settings):
    """v2 = v1 with pair P deleted; an edit set made on v1 moves a camera, flags it, deletes P and
    Q and places an image v2 does not have: rebased, it keeps the camera, the flag and Q, and says
    why P and the foreign image were dropped."""
    from guided_sfm.actions import runner
    from guided_sfm.db.models import Image

    s = reconstructed
    pairs = client.get(f"/api/v1/projects/{s.pid}/versions/{s.vid}/pairs", headers=s.owner).json()
    p, q = ([r["image_id1"], r["image_id2"]] for r in pairs[:2])
    first = client.post(url(s), json={"base_version_id": s.vid, "delete_pairs": [p]}, headers=s.owner).json()
    job = client.post(url(s, f"/{first['id']}/apply"), json={"remap": False}, headers=s.owner).json()
    assert runner.run_job(sessions, settings, job["id"]) == "succeeded"
    head = client.get(f"/api/v1/projects/{s.pid}", headers=s.owner).json()["head_version_id"]
    assert client.get(url(s, f"/{first['id']}"), headers=s.owner).json()["applied_version_id"] == head
    again = client.post(url(s, f"/{first['id']}/rebase"), headers={**s.owner, "If-Match": "1"})
    assert again.status_code == 409 and "applied already" in again.json()["detail"]  # not carried twice
    extra = Image(project_id=s.pid, name="zz-extra.jpg", width=8, height=8, seq=99)
    session.add(extra)
    session.commit()
    body = {"base_version_id": s.vid, "cameras": [camera(first_id(s)), camera(extra.id)],
            "flags": [first_id(s)], "delete_pairs": [p, q]}
    stale = client.post(url(s), json=body, headers=s.owner).json()
    refused = client.post(url(s, f"/{stale['id']}/apply"), json={}, headers=s.owner)
    assert refused.status_code == 409 and "/rebase" in refused.json()["detail"]
    assert client.post(url(s, f"/{stale['id']}/rebase"), headers=s.owner).status_code == 428
    wrong = client.post(url(s, f"/{stale['id']}/rebase"), headers={**s.owner, "If-Match": "7"})
    assert wrong.status_code == 409

    rebased = client.post(url(s, f"/{stale['id']}/rebase"), headers={**s.owner, "If-Match": "1"})
    assert rebased.status_code == 200, rebased.text
    data = rebased.json()
    assert data["base_version_id"] == head and data["revision"] == 2 and rebased.headers["ETag"] == '"2"'
    assert [c["image_id"] for c in data["cameras"]] == [first_id(s)] and data["delete_pairs"] == [q]
    report = data["report"]
    assert (report["from_version"], report["to_version"]) == (s.vid, head)
    assert report["carried"] == {"cameras": [first_id(s)], "delete_pairs": [q], "flags": [first_id(s)]}
    assert sorted((d["kind"], d["image_ids"]) for d in report["dropped"]) == [
        ("camera", [extra.id]), ("delete_pair", p)]
    assert all(f"v{head}" in d["reason"] for d in report["dropped"])
    assert client.post(url(s, f"/{stale['id']}/apply"), json={}, headers=s.owner).status_code == 202
