"""Domain errors -> HTTP status with {"detail": "..."}, mapped once for the whole API."""

from __future__ import annotations

import errno
import logging

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from sqlalchemy.exc import DataError, InterfaceError, OperationalError

from guided_sfm import errors
from guided_sfm.core.errors import (
    Cancelled,
    DomainError,
    EmptyModel,
    InvalidInput,
    MissingWorkspace,
    UnknownImage,
)
from guided_sfm.storage import StoreUnavailable

log = logging.getLogger(__name__)

STATUS: list[tuple[type[DomainError], int]] = [
    (errors.NotFound, 404),
    (errors.Forbidden, 403),
    (errors.Unauthorized, 401),
    (errors.Conflict, 409),
    (errors.PreconditionRequired, 428),
    (errors.TooLarge, 413),
    (errors.TooManyRequests, 429),
    (errors.BadUpload, 422),
    (InvalidInput, 422),
    (UnknownImage, 422),
    (EmptyModel, 409),
    (MissingWorkspace, 409),
    (Cancelled, 409),
    (DomainError, 400),
]


def status_of(exc: DomainError) -> int:
    return next(code for cls, code in STATUS if isinstance(exc, cls))


async def domain_error(_request: Request, exc: DomainError) -> JSONResponse:
    headers = {"WWW-Authenticate": "Bearer"} if isinstance(exc, errors.Unauthorized) else None
    if isinstance(exc, errors.TooManyRequests):
        headers = {"Retry-After": str(exc.retry_after)}
    detail = errors.without_paths(str(exc))
    return JSONResponse({"detail": detail}, status_code=status_of(exc), headers=headers)


async def validation_error(_request: Request, exc: RequestValidationError) -> JSONResponse:
    """Pydantic's list of problems as one sentence in `detail` (the list stays in `errors`)."""
    problems = [f"{'.'.join(str(p) for p in e['loc'] if p != 'body')}: {e['msg']}" for e in exc.errors()]
    body = {"detail": "; ".join(problems) or "invalid request",
            "errors": [{"loc": list(e["loc"]), "msg": e["msg"]} for e in exc.errors()]}
    return JSONResponse(body, status_code=422)


async def unstorable_value(_request: Request, exc: DataError) -> JSONResponse:
    """A value the database refuses (out of range, NUL in text) that validation let through."""
    reason = errors.without_paths(str(getattr(exc, "orig", exc)).splitlines()[0])
    return JSONResponse({"detail": f"a value cannot be stored: {reason}"}, status_code=422)


async def database_unavailable(_request: Request, exc: OperationalError | InterfaceError) -> JSONResponse:
    """The database went away (restart, network) or stayed locked: the request may be retried."""
    reason = errors.without_paths(str(getattr(exc, "orig", exc)).splitlines()[0][:200])
    return JSONResponse({"detail": f"the database is unavailable ({reason}); retry shortly"},
                        status_code=503, headers={"Retry-After": "5"})


async def store_unavailable(request: Request, exc: StoreUnavailable) -> JSONResponse:
    """The artifact store (S3) did not answer or refused: like the database's outage, a 503 the
    client may retry; the store's calls changed nothing the request committed."""
    log.warning("%s %s: %s", request.method, request.url.path, exc, exc_info=exc.__cause__)
    return JSONResponse({"detail": f"{exc}; nothing was stored, retry shortly"},
                        status_code=503, headers={"Retry-After": "5"})


async def disk_full(request: Request, exc: OSError) -> JSONResponse:
    """A full disk is the server's state, not a crash: 507, and the request stored nothing (every
    write goes through staging first). Any other OSError stays a 500."""
    if exc.errno not in (errno.ENOSPC, errno.EDQUOT):
        raise exc
    return JSONResponse({"detail": "the server's storage is full; nothing was stored, try again later"},
                        status_code=507)


def install(app: FastAPI) -> None:
    app.add_exception_handler(DomainError, domain_error)  # type: ignore[arg-type]
    app.add_exception_handler(RequestValidationError, validation_error)  # type: ignore[arg-type]
    app.add_exception_handler(DataError, unstorable_value)  # type: ignore[arg-type]
    app.add_exception_handler(OSError, disk_full)  # type: ignore[arg-type]
    app.add_exception_handler(StoreUnavailable, store_unavailable)  # type: ignore[arg-type]
    for unavailable in (OperationalError, InterfaceError):
        app.add_exception_handler(unavailable, database_unavailable)  # type: ignore[arg-type]
