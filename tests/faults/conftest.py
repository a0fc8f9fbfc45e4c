"""Fault tests: a real API process on a committed database of the test's own."""

from __future__ import annotations

import urllib.parse

import pytest

from tests.conftest import create_database
from tests.factories import PASSWORD
from tests.faults.live_api import LiveApi, service_env
from tests.worker.conftest import service_factory  # noqa: F401  (API in-process + a real worker)


@pytest.fixture
def live_factory(tmp_path):
    """make(**settings) -> a started LiveApi over a fresh migrated database; killed at the end."""
    made = []

    def make(**settings) -> LiveApi:
        url, drop = create_database(tmp_path)
        api = LiveApi(service_env(tmp_path / "data", url, broker_url="memory://", **settings),
                      tmp_path / f"api-{len(made)}.log")
        made.append((api, drop))
        api.database_url = url
        return api.start()

    yield make
    for api, drop in made:
        api.kill()
        drop()


def login(api: LiveApi, username: str) -> dict[str, str]:
    """Sign up and log in through the live API; the Authorization header."""
    status, body, _ = api.request("POST", "/api/v1/users", {"username": username, "password": PASSWORD})
    assert status == 201, body
    form = urllib.parse.urlencode({"username": username, "password": PASSWORD}).encode()
    status, body, _ = api.request("POST", "/api/v1/auth/token", data=form,
                                  headers={"Content-Type": "application/x-www-form-urlencoded"})
    assert status == 200, body
    return {"Authorization": f"Bearer {body['access_token']}"}
