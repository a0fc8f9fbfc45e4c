"""A missing service or browser: a skip on a laptop, a failure where they must be there.

CI (`.ci/run`) sets GUIDED_SFM_REQUIRE_SERVICES=1: it has Postgres, Redis and Chromium, so a test
that cannot reach one of them is a bug there, not a skip. Unset, such tests skip with the reason.
"""

from __future__ import annotations

import os

import pytest

REQUIRE_ENV = "GUIDED_SFM_REQUIRE_SERVICES"


def services_required() -> bool:
    return os.environ.get(REQUIRE_ENV, "") == "1"


def missing(reason: str) -> None:
    """Fail (services required) or skip (not required) a test whose service or browser is missing."""
    if services_required():
        pytest.fail(f"{reason} ({REQUIRE_ENV}=1: this must not be skipped here)", pytrace=False)
    pytest.skip(reason)
