"""Files and rows agree after any crash: files the database does not list are removed once older
than a grace period (an upload reveals its files just before it commits its rows), on the API's
start and now and then from the worker's sweeper."""

from __future__ import annotations

import logging
import shutil
import time
from pathlib import Path, PurePosixPath

from sqlalchemy import select
from sqlalchemy.orm import Session, sessionmaker

from guided_sfm.db.models import Image, Project, Version
from guided_sfm.db.session import session_scope
from guided_sfm.settings import Settings
from guided_sfm.storage import ArtifactStore

log = logging.getLogger(__name__)
SHORT_LIVED = ("upload-", "import-")  # request-time staging folders; a job's own live for hours


def reconcile(session: Session, store: ArtifactStore, grace_seconds: float) -> dict[str, int]:
    """Remove orphans older than grace_seconds: projects without a row, image files, thumbnails and
    version folders without a row, and stale upload staging folders. Returns counts by kind."""
    cutoff = time.time() - grace_seconds
    removed = {"projects": 0, "images": 0, "thumbs": 0, "versions": 0, "tmp": 0}
    root = store.root / "projects"
    live = set(session.scalars(select(Project.id)))
    for folder in sorted(root.iterdir()) if root.is_dir() else []:
        if not folder.name.isdigit():
            continue
        if int(folder.name) in live:
            _sweep_project(session, folder, cutoff, removed)
        elif _older(folder, cutoff):
            shutil.rmtree(folder, ignore_errors=True)
            removed["projects"] += 1
    session.rollback()  # nothing written; end the read
    if any(removed.values()):
        log.warning("reconcile: removed orphans %s", removed)
    return removed


def _sweep_project(session: Session, folder: Path, cutoff: float, removed: dict[str, int]) -> None:
    project_id = int(folder.name)
    rows = session.execute(select(Image.id, Image.name).where(Image.project_id == project_id)).all()
    paths = session.scalars(select(Version.path).where(Version.project_id == project_id))
    removed["images"] += _sweep(folder / "images", {name for _, name in rows}, cutoff)
    removed["thumbs"] += _sweep(folder / "thumbs", {f"{image_id}.jpg" for image_id, _ in rows}, cutoff)
    removed["versions"] += _sweep_dirs(folder / "versions", {PurePosixPath(p).name for p in paths}, cutoff)
    removed["tmp"] += _sweep_tmp(folder / "tmp", cutoff)


def reconcile_store(sessions: sessionmaker[Session], settings: Settings) -> dict[str, int]:
    """reconcile() on the settings' artifact store, in a session of its own."""
    with session_scope(sessions) as session:
        return reconcile(session, ArtifactStore(settings.artifacts_dir), settings.orphan_grace_seconds)


def _older(path: Path, cutoff: float) -> bool:
    try:
        stat = path.lstat()
    except FileNotFoundError:
        return False
    return stat.st_mtime < cutoff  # a revealed file keeps the time it was written in staging


def _sweep(folder: Path, listed: set[str], cutoff: float) -> int:
    count = 0
    for path in folder.iterdir() if folder.is_dir() else []:
        if path.name not in listed and path.is_file() and _older(path, cutoff):
            path.unlink(missing_ok=True)
            count += 1
    return count


def _sweep_dirs(folder: Path, listed: set[str], cutoff: float) -> int:
    """Version folders no row points at: a worker killed between publishing and committing."""
    count = 0
    for path in folder.iterdir() if folder.is_dir() else []:
        if path.name not in listed and path.is_dir() and _older(path, cutoff):
            shutil.rmtree(path, ignore_errors=True)
            count += 1
    return count


def _sweep_tmp(folder: Path, cutoff: float) -> int:
    count = 0
    for path in folder.iterdir() if folder.is_dir() else []:
        if path.name.startswith(SHORT_LIVED) and _older(path, cutoff):
            shutil.rmtree(path, ignore_errors=True) if path.is_dir() else path.unlink(missing_ok=True)
            count += 1
    return count
