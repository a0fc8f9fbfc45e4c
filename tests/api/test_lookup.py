"""Ids of the path, query and body: one SQL range, and one 404 naming the thing and its project."""

import pytest

from guided_sfm.db.models import MAX_ID

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
