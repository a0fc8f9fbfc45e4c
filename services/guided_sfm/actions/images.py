"""Add checked images to a project: rows, capture order, files and thumbnails, all or nothing."""

from __future__ import annotations

import os
from pathlib import Path
from typing import BinaryIO

import PIL.Image
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from guided_sfm.actions import uploads
from guided_sfm.core.workspace import Workspace
from guided_sfm.db import queries
from guided_sfm.db.models import Image, Project
from guided_sfm.errors import Conflict
from guided_sfm.storage import ArtifactStore

THUMBNAIL_SIZE = (256, 256)


def upload(session: Session, store: ArtifactStore, project: Project,
           files: list[tuple[str, BinaryIO]], limit: int) -> list[Image]:
    """Check every uploaded file in staging, then store them all (or none) in the project."""
    with store.staging(project.id, prefix="upload-") as staging:
        checked = uploads.stage_images(files, staging, limit)
        taken = set(queries.image_ids_by_name(session, project.id))
        clashes = sorted(image.name for image in checked if image.name in taken)
        if clashes:
            raise Conflict(f"the project already has images named {', '.join(clashes[:5])}")
        rows = [Image(project_id=project.id, name=i.name, width=i.width, height=i.height,
                      seq=0, taken_at=i.taken_at) for i in checked]
        session.add_all(rows)
        try:
            session.flush()
        except IntegrityError as exc:  # a racing upload took a name between the check and here
            session.rollback()
            raise Conflict("another upload stored images with these names first") from exc
        renumber(session, project.id)
        moved = _move(staging, store.images_dir(project.id), [r.name for r in rows])
        try:
            for row in rows:
                make_thumbnail(store.image_file(project.id, row.name), store.thumbnail(project.id, row.id))
            session.commit()
        except BaseException:
            session.rollback()
            for path in moved:
                path.unlink(missing_ok=True)
            raise
    return rows


def delete(session: Session, store: ArtifactStore, image: Image) -> None:
    """Remove an image no version uses (row, file, thumbnail); Conflict naming the versions that do."""
    if queries.active_job(session, image.project_id) is not None:
        raise Conflict(f"a job of project {image.project_id} is queued or running; delete images after it")
    users = [f"v{v.id}" for v in queries.versions(session, image.project_id)
             if image.name in Workspace(store.version_dir(v.path)).image_ids()]
    if users:
        raise Conflict(f"image {image.name} is used by version(s) {', '.join(users)}; "
                       "only an image no version uses can be deleted")
    project_id, name, thumb = image.project_id, image.name, store.thumbnail(image.project_id, image.id)
    session.delete(image)
    session.flush()
    renumber(session, project_id)
    session.commit()
    store.image_file(project_id, name).unlink(missing_ok=True)
    thumb.unlink(missing_ok=True)


def renumber(session: Session, project_id: int) -> None:
    """seq = capture order: EXIF time when every image has one, else file-name order."""
    rows = queries.images(session, project_id)
    by_time = all(row.taken_at for row in rows)
    for seq, row in enumerate(sorted(rows, key=lambda r: ((r.taken_at or "") if by_time else "", r.name))):
        row.seq = seq
    session.flush()


def _move(staging: Path, target: Path, names: list[str]) -> list[Path]:
    target.mkdir(parents=True, exist_ok=True)
    moved = []
    try:
        for name in names:
            # link, not replace: a file a racing upload just stored under this name is never clobbered
            os.link(staging / name, target / name)
            moved.append(target / name)
    except FileExistsError as exc:
        for path in moved:
            path.unlink(missing_ok=True)
        raise Conflict(f"the project already has an image named {Path(exc.filename2 or '').name}") from exc
    return moved


def make_thumbnail(source: Path, target: Path) -> None:
    """A small JPEG preview (JPEG rather than PNG: see the Pillow/pycolmap pitfall in cli.py)."""
    target.parent.mkdir(parents=True, exist_ok=True)
    with PIL.Image.open(source) as img:
        img.thumbnail(THUMBNAIL_SIZE)
        img.convert("RGB").save(target, "JPEG", quality=85)


def thumbnail(store: ArtifactStore, image: Image) -> Path:
    """The image's thumbnail, made again if it is missing (e.g. after an import)."""
    path = store.thumbnail(image.project_id, image.id)
    if not path.is_file():
        make_thumbnail(store.image_file(image.project_id, image.name), path)
    return path
