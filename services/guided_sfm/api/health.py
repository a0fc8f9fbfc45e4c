"""Health as design.md pins it: /health is liveness (the API and its database answer), /health/ready
adds the broker, at least one live worker and the artifact store; 503 names what is down."""

from __future__ import annotations

from collections.abc import Callable

from fastapi import APIRouter, Request
from fastapi.responses import JSONResponse
from sqlalchemy import text

from guided_sfm.errors import without_paths
from guided_sfm.storage import StoreUnavailable

Readiness = Callable[[], dict[str, str]]  # part -> problem; empty when the broker and workers are fine
router = APIRouter(tags=["health"])


def database_problem(request: Request) -> str | None:
    try:
        with request.app.state.sessions() as session:
            session.execute(text("SELECT 1"))
    except Exception as exc:  # any driver error means the same thing here: not answering
        reason = without_paths(str(exc).splitlines()[0][:200])
        return f"the database does not answer ({type(exc).__name__}: {reason})"
    return None


def store_problem(request: Request) -> str | None:
    """The store must answer and take a write: jobs and uploads need both."""
    try:
        request.app.state.store.check()
    except StoreUnavailable as exc:
        return str(exc)
    except Exception as exc:  # a store that cannot even be asked (a bucket name S3 refuses) is down
        return f"artifact store unavailable ({type(exc).__name__})"  # its text names the bucket
    return None


@router.get("/health")
def health(request: Request) -> JSONResponse:
    problem = database_problem(request)
    if problem:
        return JSONResponse({"detail": problem}, status_code=503)
    return JSONResponse({"status": "ok"})


@router.get("/health/ready")
def ready(request: Request) -> JSONResponse:
    problems = {}
    if problem := database_problem(request):
        problems["database"] = problem
    if problem := store_problem(request):
        problems["store"] = problem
    problems.update(request.app.state.readiness())
    if problems:
        detail = "not ready: " + "; ".join(f"{part}: {why}" for part, why in problems.items())
        return JSONResponse({"detail": detail, "down": sorted(problems)}, status_code=503)
    return JSONResponse({"status": "ready"})
