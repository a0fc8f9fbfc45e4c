"""Property-based requests from /openapi.json (schemathesis): no route answers 5xx, whatever the input,
and every answer matches the response schema the route declares for its status."""

import pytest
import schemathesis
from hypothesis import HealthCheck, given
from hypothesis import settings as hypothesis_settings
from schemathesis.checks import FailureGroup, not_a_server_error, response_schema_conformance

from guided_sfm.api.app import create_app
from tests.factories import make_project, signup

EXAMPLES = 12  # per operation; CI may raise it


@pytest.fixture
def api_schema(settings, sessions):
    app = create_app(settings, lambda job_id: None, sessions=sessions)
    return schemathesis.openapi.from_asgi("/openapi.json", app)


def operations(schema):
    for result in schema.get_all_operations():
        yield result.ok()


def test_no_server_errors_and_answers_match_their_schemas(api_schema, client):
    headers = signup(client, "fuzzer")
    make_project(client, headers, "fuzzed")  # so small {pid} values sometimes reach a real row
    failures = []
    for operation in operations(api_schema):

        @given(case=operation.as_strategy())
        @hypothesis_settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=list(HealthCheck),
                             database=None)
        def check(case):
            response = case.call(headers={**headers, **(case.headers or {})})
            try:
                case.validate_response(response, checks=[not_a_server_error, response_schema_conformance])
            except FailureGroup as failure:  # names the broken check and the schema
                failures.append((case.method, case.formatted_path, response.status_code,
                                 str(failure)[:300]))

        check()
    assert not failures, failures
