"""One policy for images a version's workspace has but SQL does not (no REST id): every REST answer
leaves them out (pairs, scene, compare, preview, the applied version's deleted pairs)."""

from guided_sfm.actions import runner, version_data
from guided_sfm.db.models import Image, PairDeletion, Version


def without(pairs: list[list[int]], image_id: int) -> list[list[int]]:
    return [p for p in pairs if image_id not in p]


def test_an_image_without_an_sql_row_is_left_out_of_every_answer(client, reconstructed, session,
                                                                     sessions, settings, store):
    s = reconstructed
    base = f"/api/v1/projects/{s.pid}"
    scene = client.get(f"{base}/versions/{s.vid}/scene", headers=s.owner).json()
    cam = next(c for c in scene["cameras"] if c["registered"])
    moved = {"image_id": cam["image_id"], "x": cam["x"] + 50.0, "y": cam["y"] + 50.0, "yaw_deg": 0.0}
    body = {"base_version_id": s.vid, "cameras": [moved], "rule": "paper"}
    eid = client.post(f"{base}/edits", json=body, headers=s.owner).json()["id"]
    pairs_before = client.get(f"{base}/versions/{s.vid}/pairs", headers=s.owner).json()
    preview_before = client.get(f"{base}/edits/{eid}/preview", headers=s.owner).json()
    # a partner the moved camera loses: its pairs are in every list below
    orphan = next(i for p in preview_before["pairs_to_delete"] for i in p if i != cam["image_id"])
    session.delete(session.get(Image, orphan))
    session.commit()

    pairs = client.get(f"{base}/versions/{s.vid}/pairs", headers=s.owner).json()
    assert pairs == [p for p in pairs_before if orphan not in (p["image_id1"], p["image_id2"])]
    preview = client.get(f"{base}/edits/{eid}/preview", headers=s.owner).json()
    expected = without(preview_before["pairs_to_delete"], orphan)
    assert preview["pairs_to_delete"] == expected and len(expected) < len(preview_before["pairs_to_delete"])
    assert [r["pair"] for r in preview["reasons"]] == expected
    assert preview["kept_to_connect"] == without(preview_before["kept_to_connect"], orphan)
    version = session.get(Version, s.vid)
    cameras = version_data.scene(session, store, version)["cameras"]  # uncached: the rows changed
    assert {c["image_id"] for c in cameras} == set(s.image_ids.values()) - {orphan}
    compared = client.get(f"{base}/versions/{s.vid}/compare?to={s.vid}", headers=s.owner).json()
    assert {c["image_id"] for c in compared["cameras"]} <= set(s.image_ids.values()) - {orphan}

    job_id = client.post(f"{base}/edits/{eid}/apply", json={"remap": False}, headers=s.owner).json()["id"]
    assert runner.run_job(sessions, settings, job_id) == "succeeded"
    applied = session.query(Version).filter(Version.parent_id == s.vid).one()
    deleted = session.query(PairDeletion).filter_by(version_id=applied.id).all()
    assert sorted([d.image_id1, d.image_id2] for d in deleted) == expected
