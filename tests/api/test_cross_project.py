"""A member of project A reaches nothing of project B through A's URLs: B's images, versions, edit
sets and jobs are 404 (named as not in A), A's lists never show them, and B is left as it was."""

from dataclasses import dataclass

import pytest

from guided_sfm.db.models import EditSetRow, Job, Project
from tests.factories import add_member, make_project, make_version, signup


@dataclass
class Other:
    pid: int
    ids: dict[str, int]  # thing -> id of B's row


@pytest.fixture
def other(client, session, store, tiny_reconstruction, tiny_images) -> Other:
    """Project B of another owner, with an image, a version, an edit set and a queued job."""
    bea = signup(client, "bea")
    pid = make_project(client, bea, "b")
    version = make_version(session, store, pid, tiny_reconstruction, tiny_images / "images")
    image = client.get(f"/api/v1/projects/{pid}/images", headers=bea).json()[-1]["id"]
    edit = client.post(f"/api/v1/projects/{pid}/edits", json={"base_version_id": version.id, "cameras": []},
                       headers=bea).json()["id"]
    job = client.post(f"/api/v1/projects/{pid}/reconstruct", json={}, headers=bea).json()["id"]
    return Other(pid, {"image": image, "version": version.id, "edit set": edit, "job": job})


@pytest.fixture
def amy(client, reconstructed) -> dict[str, str]:
    """An editor of A (the reconstructed project) with no role in B."""
    headers = signup(client, "amy")
    add_member(client, reconstructed.owner, reconstructed.pid, "amy", "editor")
    return headers


def through_a(pid: int, vid: int) -> list[tuple[str, str, str, dict]]:
    """(thing, method, A's url with {id} for B's row, request kwargs)."""
    p = f"/api/v1/projects/{pid}"
    return [
        ("image", "GET", p + "/images/{id}/thumbnail", {}),
        ("image", "GET", p + "/images/{id}/file", {}),
        ("version", "GET", p + "/versions/{id}/scene", {}),
        ("version", "GET", p + "/versions/{id}/pairs", {}),
        ("version", "GET", p + "/versions/{id}/scene?max_points=50", {}),
        ("version", "GET", p + "/versions/{id}/pairs?order=inliers&limit=2", {}),
        ("version", "GET", p + "/versions/{id}/suspects", {}),
        ("version", "GET", p + "/versions/{id}/export", {}),
        ("version", "POST", p + "/versions/{id}/restore", {}),
        ("version", "GET", p + "/versions/{id}/compare?to=" + str(vid), {}),
        ("version", "GET", p + f"/versions/{vid}/compare?to={{id}}", {}),
        ("version", "POST", p + "/edits", {"json": {"base_version_id": "{id}", "cameras": []}}),
        ("edit set", "GET", p + "/edits/{id}", {}),
        ("edit set", "GET", p + "/edits/{id}/preview", {}),
        ("edit set", "PUT", p + "/edits/{id}", {"json": {"base_version_id": vid, "cameras": []},
                                                "headers": {"If-Match": "1"}}),
        ("edit set", "POST", p + "/edits/{id}/apply", {"json": {"remap": False}}),
        ("edit set", "DELETE", p + "/edits/{id}", {}),
    ]


def send(client, headers, method, url, kwargs, row_id):
    json = kwargs.get("json")
    if json is not None:
        json = {k: row_id if v == "{id}" else v for k, v in json.items()}
    return client.request(method, url.replace("{id}", str(row_id)), json=json,
                          headers={**headers, **kwargs.get("headers", {})})


def test_b_rows_through_a_urls_are_404(client, session, reconstructed, other, amy):
    s = reconstructed
    for thing, method, url, kwargs in through_a(s.pid, s.vid):
        response = send(client, amy, method, url, kwargs, other.ids[thing])
        assert response.status_code == 404, (method, url, response.status_code, response.text)
        assert response.json()["detail"] == f"{thing} {other.ids[thing]} not found in project {s.pid}"
    session.expire_all()
    edit_set = session.get(EditSetRow, other.ids["edit set"])
    assert edit_set is not None and edit_set.revision == 1  # neither replaced nor deleted
    assert session.get(Project, other.pid).head_version_id == other.ids["version"]  # nothing restored
    assert [j.id for j in session.query(Job).filter_by(project_id=other.pid)] == [other.ids["job"]]


def test_b_jobs_are_404_to_a_member(client, session, other, amy):
    job = other.ids["job"]
    for method, url in (("GET", f"/api/v1/jobs/{job}"), ("POST", f"/api/v1/jobs/{job}/cancel")):
        response = client.request(method, url, headers=amy)
        assert response.status_code == 404 and response.json()["detail"] == f"job {job} not found"
    session.expire_all()
    assert session.get(Job, job).cancel_requested is False


def test_a_lists_never_show_b_rows(client, reconstructed, other, amy):
    p = f"/api/v1/projects/{reconstructed.pid}"
    listed = {
        "image": [i["id"] for i in client.get(p + "/images", headers=amy).json()],
        "version": [v["id"] for v in client.get(p + "/versions", headers=amy).json()],
        "edit set": [e["id"] for e in client.get(p + "/edits", headers=amy).json()],
        "job": [j["id"] for j in client.get(p + "/jobs", headers=amy).json()],
    }
    assert listed["image"] and listed["version"]  # A has its own rows: the lists are not just empty
    for thing, ids in listed.items():
        assert other.ids[thing] not in ids, (thing, ids)
    assert [p["id"] for p in client.get("/api/v1/projects", headers=amy).json()] == [reconstructed.pid]
