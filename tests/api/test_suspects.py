"""GET .../versions/{vid}/suspects (design.md v1.1, Triage): REST ids, contract shape, roles."""

from tests.factories import add_member, signup


def url(s, vid=None):
    return f"/api/v1/projects/{s.pid}/versions/{vid or s.vid}/suspects"


def test_viewer_reads_suspects_in_rest_ids(client, reconstructed):
    s = reconstructed
    viewer = signup(client, "vera")
    assert client.get(url(s), headers=viewer).status_code == 404  # not yet a member
    add_member(client, s.owner, s.pid, "vera", "viewer")
    response = client.get(url(s), headers=viewer)
    assert response.status_code == 200, response.text
    body = response.json()
    assert set(body) == {"suspects", "runs"}
    ids = set(s.image_ids.values())
    scores = [x["score"] for x in body["suspects"]]
    assert scores == sorted(scores, reverse=True) and all(0 <= x <= 1 for x in scores)
    assert {x["image_id"] for x in body["suspects"]} == ids  # every camera of the one model
    assert all(isinstance(r, str) for x in body["suspects"] for r in x["reasons"])
    assert body["runs"], "the tiny sample folds: at least one run is expected"
    seen: set[int] = set()
    for run in body["runs"]:
        assert set(run) == {"image_ids", "reason", "proposal"} and run["reason"]
        assert not seen & set(run["image_ids"]) and set(run["image_ids"]) <= ids  # disjoint
        seen |= set(run["image_ids"])
        cameras = run["proposal"]["cameras"]
        assert [c["image_id"] for c in cameras] == run["image_ids"]
        assert all(set(c) == {"image_id", "x", "y", "yaw_deg"} for c in cameras)


def test_a_proposal_is_an_edit_set_the_api_accepts(client, reconstructed):
    s = reconstructed
    run = client.get(url(s), headers=s.owner).json()["runs"][0]
    body = {"base_version_id": s.vid, "cameras": run["proposal"]["cameras"]}
    response = client.post(f"/api/v1/projects/{s.pid}/edits", json=body, headers=s.owner)
    assert response.status_code == 201, response.text


def test_non_member_gets_404(client, reconstructed):
    s = reconstructed
    stranger = signup(client, "stranger")
    response = client.get(url(s), headers=stranger)
    assert response.status_code == 404
    assert client.get(url(s, vid=10**6), headers=s.owner).status_code == 404

