"""Login and sign-up are throttled per username and per client address (429 with Retry-After); a
forwarded address is believed only from a trusted proxy."""

from __future__ import annotations

import urllib.parse

from tests.factories import PASSWORD
from tests.faults.conftest import login

FORM = {"Content-Type": "application/x-www-form-urlencoded"}


def _token(api, username: str, password: str, **headers) -> tuple[int, dict, dict]:
    data = urllib.parse.urlencode({"username": username, "password": password}).encode()
    return api.request("POST", "/api/v1/auth/token", data=data, headers={**FORM, **headers})


def test_wrong_passwords_lock_the_account_and_floods_lock_the_address(live_factory):
    api = live_factory(login_attempts_per_user=3, login_attempts_per_address=6, login_window_seconds=60,
                       trusted_proxies="127.0.0.1")
    login(api, "alice")  # one sign-up and one login from this address
    codes = [_token(api, "alice", "wrong")[0] for _ in range(3)]
    assert codes == [401, 401, 401]
    status, body, headers = _token(api, "alice", PASSWORD)  # even the right password waits now
    assert status == 429 and "this account" in body["detail"], body
    assert 1 <= int(headers["retry-after"]) <= 60
    assert _token(api, "bob", "wrong")[0] == 401  # another account is not locked by alice's
    status, body, headers = _token(api, "carol", "x")  # the address used its 6 attempts
    assert status == 429 and "your address" in body["detail"] and "retry-after" in headers, body
    status, body, _ = api.request("POST", "/api/v1/users", {"username": "dave", "password": PASSWORD})
    assert status == 429, body
    # behind the trusted proxy (loopback here) each forwarded client counts on its own
    assert _token(api, "carol", "x", **{"X-Forwarded-For": "203.0.113.9"})[0] == 401
    assert _token(api, "carol", "x", **{"X-Forwarded-For": "203.0.113.9, 127.0.0.1"})[0] == 401


def test_forwarded_addresses_are_ignored_from_untrusted_peers(live_factory):
    api = live_factory(login_attempts_per_address=2, login_window_seconds=60)
    for forwarded in ("198.51.100.1", "198.51.100.2"):
        assert _token(api, "x", "y", **{"X-Forwarded-For": forwarded})[0] == 401
    assert _token(api, "x", "y", **{"X-Forwarded-For": "198.51.100.3"})[0] == 429
