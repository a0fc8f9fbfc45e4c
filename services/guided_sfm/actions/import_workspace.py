"""Import an existing COLMAP workspace (zip of database.db, sparse/0/, images/) as a first version."""

from __future__ import annotations

import zipfile
from collections.abc import Callable
from pathlib import Path, PurePosixPath
from typing import BinaryIO

from sqlalchemy.orm import Session

from guided_sfm import jobs
from guided_sfm.actions import uploads
from guided_sfm.actions.context import JobContext, NewImage, Produced
from guided_sfm.core import colmap_db
from guided_sfm.core.errors import InvalidInput
from guided_sfm.core.workspace import Workspace
from guided_sfm.db import queries
from guided_sfm.db.models import Job, Project
from guided_sfm.errors import BadUpload, Conflict
from guided_sfm.storage import Store, upload_key

REQUIRED = ("database.db", "sparse/0/")


def queue(session: Session, store: Store, submit: Callable[[int], None], project: Project,
          user_id: int, upload: BinaryIO, limit: int) -> Job:
    """Keep a checked workspace zip in the project and queue its import; 409 unless the project is
    empty and idle (checked before the upload is written, and again where the job is queued)."""
    _check_idle(session, project.id)
    session.commit()  # copying a large zip takes long: hold no lock (SQLite's is the whole file)
    kept = _keep(store, project.id, upload, limit)
    try:
        _check_idle(session, project.id)
        return jobs.queue(session, submit, project, "import", user_id, {"upload": kept}, None)
    except BaseException:
        store.remove(kept)
        raise


def _check_idle(session: Session, project_id: int) -> None:
    if not queries.is_empty(session, project_id):
        raise Conflict(f"project {project_id} already has images or versions; import needs an empty project")
    if queries.active_job(session, project_id) is not None:
        raise Conflict(f"project {project_id} already has a queued or running job")


def _keep(store: Store, project_id: int, upload: BinaryIO, limit: int) -> str:
    """The upload, copied within the limit and checked in staging, then stored among the uploads;
    its key."""
    with store.staging(project_id, prefix="import-") as staging:
        staged = staging / "workspace.zip"
        uploads.copy_limited(upload, staged, uploads.Budget(limit), "file")
        _check_archive(staged, limit)
        kept = upload_key(project_id, staging.name)
        store.put(kept, staged)
    return kept


def _check_archive(path: Path, limit: int) -> None:
    """Refuse an unsafe or incomplete workspace zip before a job is queued."""
    with uploads.open_zip(path, "the workspace zip") as archive:
        _members(archive, uploads.Budget(limit))


def _members(archive: zipfile.ZipFile, budget: uploads.Budget) -> list[tuple[zipfile.ZipInfo, PurePosixPath]]:
    entries = uploads.zip_entries(archive, budget)
    root = _common_root([p for _, p in entries])
    relative = [(info, PurePosixPath(*p.parts[len(root):])) for info, p in entries]
    names = {str(p) for _, p in relative}
    if "database.db" not in names or not any(n.startswith("sparse/0/") for n in names):
        raise BadUpload("the zip must hold database.db, sparse/0/ and images/ (at its root or in one folder)")
    if not any(n.startswith("images/") for n in names):
        raise BadUpload("the zip has no images/ folder")
    return relative


def _common_root(paths: list[PurePosixPath]) -> tuple[str, ...]:
    """A single top folder wrapping everything (zipping a folder) is looked through."""
    tops = {p.parts[0] for p in paths if len(p.parts) > 1} | {"" for p in paths if len(p.parts) == 1}
    return (tops.pop(),) if len(tops) == 1 and "" not in tops else ()


def run(context: JobContext, work: Path) -> Produced:
    key, upload = context.job.params["upload"], context.scratch / "upload.zip"
    context.store.fetch(key, upload)  # the store away: the upload stays for the next try
    try:
        images = _extract(upload, work, context.settings.max_upload_bytes, context.settings.max_image_mpx)
    finally:
        upload.unlink(missing_ok=True)
        context.store.remove(key)
    colmap_db.check_untrusted(work / "database.db")  # before pycolmap or we read a row of it
    workspace = Workspace(work)
    location = context.store.image_location(context.job.project_id)
    workspace.write_meta({"image_dir": location, "imported": True})
    workspace.number_models_largest_first()  # sparse/0 is the largest, as a reconstruction's
    names = set(workspace.image_ids())
    missing = sorted(names - {image.name for image in images})
    if missing:
        raise InvalidInput(f"images/ lacks {len(missing)} images of database.db, e.g. {missing[0]}")
    context.progress("scene", 0.5)
    workspace.write_scene()
    stats = workspace.stats()
    message = f"imported a COLMAP workspace: {stats['num_registered']} of {stats['num_images']} registered"
    return Produced(work, "import", message, None, stats, new_images=images, images_from=work / "images")


def _extract(upload: Path, work: Path, limit: int, limit_mpx: int) -> list[NewImage]:
    budget = uploads.Budget(limit)
    images = []
    with uploads.open_zip(upload, "the workspace zip") as archive:
        for info, path in _members(archive, budget):
            if path.parts[0] == "images" and len(path.parts) > 2:
                raise BadUpload(f"{info.filename}: images/ must be flat (no sub-folders)")
            uploads.extract(archive, info, work / path, budget)
            if path.parts[0] == "images":
                name = uploads.image_name(path.name, "zip entry")
                images.append(uploads.check_image(work / path, name, limit_mpx))
    return images
