"""fake_api.py answers as the real API would: every route it serves exists in the real /openapi.json
with that method, and every JSON answer matches the response schema declared there for its status
(errors: the {"detail": ...} shape). No browser: the fake is called directly."""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field

import jsonschema_rs
import pytest

from guided_sfm.api.app import create_app
from tests.e2e.fake_api import ORIGIN, FakeApi, camera

EDIT = {"base_version_id": 1, "cameras": [{"image_id": 2, "x": 1.5, "y": 0.5, "yaw_deg": 80.0}],
        "delete_pairs": [[1, 3]], "flags": [], "rule": "default", "tolerances": {}}


@dataclass
class FakeRequest:
    """The parts of a Playwright request the fake reads."""

    method: str
    url: str
    post_data_json: dict | None = None
    headers: dict[str, str] = field(default_factory=dict)


def calls() -> list[tuple[str, str, dict | None, dict]]:
    """(method, path under /api/v1, JSON body, headers) in an order an editor session would use."""
    p = "/projects/1"
    return [
        ("POST", "/auth/token", None, {}), ("GET", "/projects", None, {}), ("GET", p, None, {}),
        ("GET", p + "/versions", None, {}), ("GET", p + "/members", None, {}),
        ("GET", p + "/jobs", None, {}), ("GET", p + "/edits", None, {}),
        ("GET", p + "/versions/2/scene", None, {}), ("GET", p + "/versions/2/pairs", None, {}),
        ("GET", p + "/versions/2/compare?to=1", None, {}), ("POST", p + "/edits", EDIT, {}),
        ("GET", p + "/edits", None, {}), ("GET", p + "/edits/1", None, {}),
        ("PUT", p + "/edits/1", EDIT, {"if-match": '"1"'}), ("PUT", p + "/edits/1", EDIT, {"if-match": "1"}),
        ("GET", p + "/edits/1/preview", None, {}), ("GET", p + "/versions/2/suspects", None, {}),
    ]


@pytest.fixture(scope="module")
def openapi(tmp_path_factory) -> dict:
    from tests.conftest import make_settings

    settings = make_settings(tmp_path_factory.mktemp("openapi"), "sqlite:///:memory:")
    return create_app(settings, lambda job_id: None).openapi()


def operation(openapi: dict, method: str, path: str) -> dict:
    """The real API's operation for a concrete path (ids and query left out)."""
    for template, operations in openapi["paths"].items():
        pattern = "^/api/v1" + re.sub(r"\{[^}]+\}", "[^/]+", template.removeprefix("/api/v1")) + "$"
        if re.match(pattern, "/api/v1" + path.split("?")[0]) and method.lower() in operations:
            return operations[method.lower()]
    raise AssertionError(f"the fake serves {method} {path}, which the real API does not have")


def response_schema(openapi: dict, op: dict, status: int) -> dict:
    declared = op["responses"].get(str(status))
    if declared is None and status >= 400:  # errors share one shape (guided_sfm.api.errors)
        return {"type": "object", "required": ["detail"], "properties": {"detail": {"type": "string"}}}
    assert declared is not None, f"{op['operationId']} declares no {status} answer"
    schema = declared["content"]["application/json"]["schema"]
    return {**schema, "components": openapi["components"]}


def test_every_fake_answer_matches_the_real_schema(openapi):
    fake = FakeApi(head=2, older={1: [camera(i, float(i)) for i in range(1, 6)]})
    statuses = []
    for method, path, body, headers in calls():
        request = FakeRequest(method, ORIGIN + "/api/v1" + path, body, headers)
        status, answer = fake.answer(method, path.split("?")[0], request)
        op = operation(openapi, method, path)
        statuses.append(status)
        errors = [e.message for e in jsonschema_rs.validator_for(
            response_schema(openapi, op, status)).iter_errors(json.loads(json.dumps(answer)))]
        assert not errors, (method, path, status, errors[:3], answer)
    assert statuses.count(409) == 1 and 404 not in statuses  # the stale If-Match, nothing unknown


def test_the_fake_thumbnail_route_exists_for_real(openapi):
    op = operation(openapi, "GET", "/projects/1/images/3/thumbnail")
    assert "200" in op["responses"]


def test_the_triage_answers_of_the_offline_tests_match_the_real_schema(openapi):
    """The hand-made suspects, runs and proposals test_triage_offline serves are real answers' shapes."""
    from tests.e2e.test_triage_offline import TRIAGE

    fake = FakeApi(head=2)
    fake.suspects = TRIAGE
    path = "/projects/1/versions/2/suspects"
    status, answer = fake.answer("GET", path, FakeRequest("GET", ORIGIN + "/api/v1" + path))
    schema = response_schema(openapi, operation(openapi, "GET", path), status)
    errors = [e.message for e in jsonschema_rs.validator_for(schema).iter_errors(answer)]
    assert status == 200 and not errors, errors[:3]
