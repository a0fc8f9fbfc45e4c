"""Files and rows agree after any crash: the collection pass. Keys the database does not reference
are removed from the store once older than a grace period (an upload reveals its files just before
it commits its rows; a job publishes its version just before it commits its row), on the API's start
and now and then from each worker's sweeper. Works on either backend through the store's keys."""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from pathlib import PurePosixPath

from sqlalchemy import select
from sqlalchemy.orm import Session, sessionmaker

from guided_sfm.db.models import Image, Project, Version
from guided_sfm.db.session import session_scope
from guided_sfm.settings import Settings
from guided_sfm.storage import Store, open_store, project_prefix

log = logging.getLogger(__name__)
SHORT_LIVED = ("upload-", "import-", "thumb-")  # a request's staging; a job's, an export's may live for hours


def reconcile(session: Session, store: Store, grace_seconds: float,
              job_seconds: Callable[[int], float] | None = None) -> dict[str, int]:
    """Remove orphans older than grace_seconds: projects without a row, image files, thumbnails and
    versions without a row (published or half-published), stale request staging in the data dir,
    and scratch dirs of dead processes. With job_seconds (a job's time limit in a project of so
    many images) also the data dir's other staging (a job's, an export's, a restore's) once older
    than that limit: no live process outlives it. Returns counts by kind."""
    now = time.time()
    cutoff = now - grace_seconds
    staging_cutoff = None if job_seconds is None else (lambda images: min(cutoff, now - job_seconds(images)))
    removed = {"projects": 0, "images": 0, "thumbs": 0, "versions": 0, "tmp": 0}
    live = set(session.scalars(select(Project.id)))
    for name in store.children("projects"):
        if not name.isdigit():
            continue
        if int(name) in live:
            _sweep_project(session, store, int(name), (cutoff, staging_cutoff), removed)
        elif _older(store, project_prefix(int(name)), cutoff):
            store.remove(project_prefix(int(name)))
            removed["projects"] += 1
    session.rollback()  # nothing written; end the read
    removed["tmp"] += store.clear_stale_scratch()
    if any(removed.values()):
        log.warning("reconcile: removed orphans %s", removed)
    return removed


def _sweep_project(session: Session, store: Store, project_id: int,
                   cutoffs: tuple[float, Callable[[int], float] | None], removed: dict[str, int]) -> None:
    """cutoffs: the grace's, and the one of staging other than a request's (by image count)."""
    cutoff, staging_cutoff = cutoffs
    prefix = project_prefix(project_id)
    rows = session.execute(select(Image.id, Image.name).where(Image.project_id == project_id)).all()
    paths = session.scalars(select(Version.path).where(Version.project_id == project_id))
    thumbs, versions = {f"{image_id}.jpg" for image_id, _ in rows}, {PurePosixPath(p).name for p in paths}
    removed["images"] += _sweep(store, f"{prefix}/images", _unless({name for _, name in rows}, cutoff))
    removed["thumbs"] += _sweep(store, f"{prefix}/thumbs", _unless(thumbs, cutoff))
    removed["versions"] += _sweep(store, f"{prefix}/versions", _unless(versions, cutoff))
    # the data dir's staging: a request's after the grace; a job's, an export's or a restore's
    # once older than a job may run (kept when no limit is given)
    long_cutoff = None if staging_cutoff is None else staging_cutoff(len(rows))
    removed["tmp"] += _sweep(store, f"{prefix}/tmp",
                             lambda name: cutoff if name.startswith(SHORT_LIVED) else long_cutoff)


def reconcile_store(sessions: sessionmaker[Session], settings: Settings) -> dict[str, int]:
    """reconcile() on the settings' artifact store, in a session of its own."""
    with session_scope(sessions) as session:
        return reconcile(session, open_store(settings), settings.orphan_grace_seconds, settings.job_seconds)


def _sweep(store: Store, prefix: str, cutoff_of: Callable[[str], float | None]) -> int:
    """Remove the children of prefix older than their cutoff (None: kept); the count removed."""
    count = 0
    for name in store.children(prefix):
        cutoff = cutoff_of(name)
        if cutoff is not None and _older(store, f"{prefix}/{name}", cutoff):
            store.remove(f"{prefix}/{name}")
            count += 1
    return count


def _unless(listed: set[str], cutoff: float) -> Callable[[str], float | None]:
    """Children a row names are kept; the others go once older than cutoff."""
    return lambda name: None if name in listed else cutoff


def _older(store: Store, key: str, cutoff: float) -> bool:
    """Changed before cutoff (asked only of orphans: on S3 a folder's time lists its objects)."""
    changed = store.changed(key)
    return changed is not None and changed < cutoff
