"""Service errors beyond the core's: requests the state of the service refuses (mapped once in api/errors)."""

import re

from guided_sfm.core.errors import DomainError


class NotFound(DomainError):
    """The thing does not exist, or the caller has no role in its project."""


class Forbidden(DomainError):
    """The caller's role does not allow this change."""


class Conflict(DomainError):
    """The request clashes with the current state (a job runs, a newer revision, a taken name)."""


class PreconditionRequired(DomainError):
    """An update needs If-Match with the revision it was based on."""


class TooLarge(DomainError):
    """An upload exceeds the configured limit."""


class BadUpload(DomainError):
    """An upload is not what the route accepts (not an image, corrupt, unsafe zip entry)."""


class Unauthorized(DomainError):
    """No valid credentials."""


class TooManyRequests(DomainError):
    """Too many attempts from one client or on one account; retry after `retry_after` seconds."""

    def __init__(self, message: str, retry_after: int) -> None:
        super().__init__(message)
        self.retry_after = retry_after


_SERVER_PATH = re.compile(r"(?<![\w.:/~-])/(?!api/)(?:[^\s/'\"():,]+/)+([^\s/'\"():,]*)")


def without_paths(text: str) -> str:
    """The text with server file paths cut to their last part: errors leave the server without them."""
    return _SERVER_PATH.sub(lambda found: found.group(1) or "(a server path)", text)
