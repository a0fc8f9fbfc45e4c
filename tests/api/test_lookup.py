"""Ids of the path, query and body: one SQL range, and one 404 naming the thing and its project."""

import pytest

from guided_sfm.db.models import MAX_ID
from tests.factories import make_project, make_version, signup

TOO_BIG = MAX_ID + 1


def id_places(s) -> list[tuple[str, str, dict, str, int]]:
    """(method, url with {id}, request kwargs, field name, status for the largest id) for each kind of
    id the API reads."""
    p = f"/api/v1/projects/{s.pid}"
    body = {"json": {"base_version_id": "{id}", "cameras": []}}
    return [
        ("GET", p + "/versions/{id}/scene", {}, "vid", 404),
        ("GET", p + "/images/{id}/file", {}, "image_id", 404),
        ("GET", p + "/edits/{id}", {}, "eid", 404),
        ("GET", "/api/v1/jobs/{id}", {}, "job_id", 404),
        ("GET", p + f"/versions/{s.vid}/pairs?image_id={{id}}", {}, "image_id", 200),  # a filter
        ("GET", p + f"/versions/{s.vid}/compare?to={{id}}", {}, "to", 404),
        ("POST", p + "/edits", body, "base_version_id", 404),
    ]


def send(client, s, method, url, kwargs, value):
    if "json" in kwargs:
        kwargs = {"json": {**kwargs["json"], "base_version_id": value}}
    return client.request(method, url.replace("{id}", str(value)), headers=s.owner, **kwargs)


def test_ids_beyond_the_sql_range_are_refused_by_one_bound(client, reconstructed):
    s = reconstructed
    for method, url, kwargs, field, largest in id_places(s):
        over = send(client, s, method, url, kwargs, TOO_BIG)
        assert over.status_code == 422, (url, over.text)
        assert f"{field}: " in over.json()["detail"] and str(MAX_ID) in over.json()["detail"], over.text
        assert send(client, s, method, url, kwargs, MAX_ID).status_code == largest, url


@pytest.fixture
def foreign(client, session, store, reconstructed, tiny_reconstruction, tiny_images):
    """Ids of another project of the same owner: an image, a version, an edit set, a job."""
    s = reconstructed
    pid = make_project(client, s.owner, "other")
    version = make_version(session, store, pid, tiny_reconstruction, tiny_images / "images")
    image_id = client.get(f"/api/v1/projects/{pid}/images", headers=s.owner).json()[0]["id"]
    edit = client.post(f"/api/v1/projects/{pid}/edits", json={"base_version_id": version.id},
                       headers=s.owner).json()["id"]
    job = client.post(f"/api/v1/projects/{pid}/reconstruct", json={}, headers=s.owner).json()["id"]
    return {"image": image_id, "version": version.id, "edit set": edit, "job": job}


def lookups(s) -> list[tuple[str, str, str, dict]]:
    """(thing, method, url with {id}, request kwargs) for every route that finds a row of the project."""
    p = f"/api/v1/projects/{s.pid}"
    return [
        ("image", "GET", p + "/images/{id}/thumbnail", {}),
        ("image", "GET", p + "/images/{id}/file", {}),
        ("version", "GET", p + "/versions/{id}/scene", {}),
        ("version", "GET", p + "/versions/{id}/pairs", {}),
        ("version", "GET", p + "/versions/{id}/export", {}),
        ("version", "POST", p + "/versions/{id}/restore", {}),
        ("version", "GET", p + f"/versions/{s.vid}/compare?to={{id}}", {}),
        ("version", "POST", p + "/edits", {"json": {"base_version_id": "{id}"}}),
        ("edit set", "GET", p + "/edits/{id}", {}),
        ("edit set", "GET", p + "/edits/{id}/preview", {}),
        ("edit set", "DELETE", p + "/edits/{id}", {}),
        ("edit set", "POST", p + "/edits/{id}/apply", {}),
        ("edit set", "PUT", p + "/edits/{id}",
         {"json": {"base_version_id": s.vid}, "headers": {"If-Match": "1"}}),
    ]


def test_a_row_of_another_project_is_404_naming_the_thing_and_the_project(client, reconstructed, foreign):
    s = reconstructed
    for thing, method, url, kwargs in lookups(s):
        for row_id in (foreign[thing], 99999):
            json = {k: row_id if v == "{id}" else v for k, v in kwargs.get("json", {}).items()} or None
            headers = {**s.owner, **kwargs.get("headers", {})}
            response = client.request(method, url.replace("{id}", str(row_id)), json=json, headers=headers)
            assert response.status_code == 404, (url, row_id, response.text)
            assert response.json()["detail"] == f"{thing} {row_id} not found in project {s.pid}", url


def test_a_stranger_learns_nothing_of_rows_or_jobs(client, reconstructed, foreign):
    s = reconstructed
    stranger = signup(client, "stranger")
    for _, method, url, kwargs in lookups(s):
        response = client.request(method, url.replace("{id}", "1"), headers=stranger,
                                  json=kwargs.get("json") and {"base_version_id": 1})
        assert response.status_code == 404 and response.json()["detail"] == f"project {s.pid} not found"
    for job_id in (foreign["job"], 99999):
        response = client.get(f"/api/v1/jobs/{job_id}", headers=stranger)
        assert response.status_code == 404 and response.json()["detail"] == f"job {job_id} not found"
