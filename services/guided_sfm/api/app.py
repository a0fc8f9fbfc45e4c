"""create_app(settings, submit): the FastAPI app with the REST API at /api/v1 and the frontend at /."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import PIL.Image  # noqa: F401  (before pycolmap: Pillow loaded after it crashes on PNG save)
from fastapi import FastAPI
from fastapi.staticfiles import StaticFiles
from sqlalchemy.orm import Session, sessionmaker

from guided_sfm.api import errors, health
from guided_sfm.api.concurrency import ConcurrencyLimit, pool_capacity
from guided_sfm.api.headers import SecurityHeaders
from guided_sfm.api.health import Readiness
from guided_sfm.api.limits import BodyLimit
from guided_sfm.api.routes import (
    activity,
    auth,
    comments,
    edits,
    images,
    jobs,
    members,
    presence,
    projects,
    tokens,
    users,
    versions,
    webhooks,
)
from guided_sfm.api.schemas import InvalidOut
from guided_sfm.api.throttle import Throttle
from guided_sfm.db.session import make_sessionmaker
from guided_sfm.settings import Settings
from guided_sfm.storage import open_store

FRONTEND = Path(__file__).resolve().parents[3] / "frontend"
API_PREFIX = "/api/v1"
def create_app(settings: Settings, submit: Callable[[int], None],
               sessions: sessionmaker[Session] | None = None, readiness: Readiness | None = None) -> FastAPI:
    """The API; `submit(job_id)` enqueues a committed job (worker.celery_app.submitter in production);
    `readiness()` names what is down of the broker and the workers (worker.health.readiness)."""
    settings = settings.with_secret()
    app = FastAPI(title="Guided SfM", version="1", openapi_url="/openapi.json",
                  docs_url="/docs", redoc_url=None,  # 422 as errors.py answers it, not FastAPI's list
                  responses={422: {"model": InvalidOut, "description": "Invalid request"}})
    app.state.settings = settings
    app.state.sessions = sessions or make_sessionmaker(settings)
    app.state.store = open_store(settings)
    app.state.store.prepare()  # a new data dir's artifacts folder (the readiness probe makes none)
    app.state.submit = submit
    app.state.readiness = readiness or dict
    app.state.throttle = Throttle(settings)
    errors.install(app)
    for module in (health, users, auth, tokens, projects, members, images, jobs, versions, edits, webhooks):
        app.include_router(module.router, prefix=API_PREFIX)
    for module in (activity, comments, presence):  # team review (v1.1)
        app.include_router(module.router, prefix=API_PREFIX)
    app.add_middleware(BodyLimit, upload_limit=settings.max_upload_bytes)
    app.add_middleware(SecurityHeaders, index_html=FRONTEND / "index.html")
    if (capacity := pool_capacity(app.state.sessions)) is not None:
        app.add_middleware(ConcurrencyLimit, limit=capacity)

    if FRONTEND.is_dir():
        app.mount("/", StaticFiles(directory=FRONTEND, html=True), name="frontend")
    return app
