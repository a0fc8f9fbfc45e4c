"""Health as design.md pins it: /health is liveness (the API and its database answer), /health/ready
adds the broker and at least one live worker; 503 names what is down."""

from __future__ import annotations

from collections.abc import Callable

from fastapi import APIRouter, Request
from fastapi.responses import JSONResponse
from sqlalchemy import text

from guided_sfm.errors import without_paths

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
    problems.update(request.app.state.readiness())
    if problems:
        detail = "not ready: " + "; ".join(f"{part}: {why}" for part, why in problems.items())
        return JSONResponse({"detail": detail, "down": sorted(problems)}, status_code=503)
    return JSONResponse({"status": "ready"})
