"""Add checked images to a project: rows, capture order, files and thumbnails, all or nothing."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

import PIL.Image
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from guided_sfm.actions import uploads
from guided_sfm.actions.context import NewImage
from guided_sfm.core.workspace import DATABASE, Workspace
from guided_sfm.db import queries
from guided_sfm.db.models import Image, Project
from guided_sfm.errors import Conflict
from guided_sfm.storage import Blob, Store, image_key, thumb_key


@dataclass(frozen=True)
class Uploaded:
    """An upload's outcome: the images it added, and those it sent again (same name and bytes as
    an image already stored: kept as they were, so a batch that failed can be sent again)."""

    added: list[Image]
    already: list[Image]


def upload(session: Session, store: Store, project: Project,
           files: list[tuple[str, BinaryIO]], limit: int, max_mpx: int | None = None) -> Uploaded:
    """Check every uploaded file (and make its thumbnail) in staging with no transaction open, then
    store them all (or none) in one short write transaction."""
    project_id = project.id
    session.commit()  # staging a large upload takes long: hold no lock (SQLite's is the whole file)
    with store.staging(project_id, prefix="upload-") as staging:
        checked = uploads.with_hashes(uploads.stage_images(files, staging, limit, max_mpx), staging)
        already = _already_stored(session, store, project_id, checked, staging)
        rows = _insert(session, project_id, [i for i in checked if i.name not in already])
        revealed = _reveal(store, project_id, staging, rows)
        try:
            session.commit()
        except BaseException:
            session.rollback()
            for key in revealed:
                store.remove(key)
            raise
    return Uploaded(rows, [already[name] for name in sorted(already)])


def _already_stored(session: Session, store: Store, project_id: int, checked: list[NewImage],
                    scratch: Path) -> dict[str, Image]:
    """name -> stored image, for the uploaded files whose name and bytes are already there (a
    row from before hashes were kept is hashed from its stored file). Same name, other bytes: left
    to _insert's 409."""
    rows = {row.name: row for row in queries.images(session, project_id)}
    found = {}
    for image in checked:
        row = rows.get(image.name)
        if row is None:
            continue
        if row.sha256 is None:
            copy = scratch / "stored-image"
            try:
                store.fetch(image_key(project_id, row.name), copy)
            except FileNotFoundError:
                continue
            row.sha256 = uploads.file_sha256(copy)
            copy.unlink()
        if row.sha256 == image.sha256:
            found[image.name] = row
    return found


def delete(session: Session, store: Store, image: Image) -> None:
    """Remove an image no version uses (row, file, thumbnail); Conflict naming the versions that do."""
    if queries.active_job(session, image.project_id) is not None:
        raise Conflict(f"a job of project {image.project_id} is queued or running; delete images after it")
    users = [f"v{v.id}" for v in queries.versions(session, image.project_id)
             if image.name in _image_names(store, v.path)]
    if users:
        raise Conflict(f"image {image.name} is used by version(s) {', '.join(users)}; "
                       "only an image no version uses can be deleted")
    keys = [image_key(image.project_id, image.name), thumb_key(image.project_id, image.id)]
    project_id = image.project_id
    session.delete(image)
    session.flush()
    renumber(session, project_id)
    session.commit()
    store.remove_committed(keys)


def _image_names(store: Store, version: str) -> set[str]:
    with store.reading(version, only=(DATABASE,)) as root:
        return set(Workspace(root).image_ids())


def _insert(session: Session, project_id: int, checked: list[NewImage]) -> list[Image]:
    """The rows, flushed: from here the names are this upload's (the unique index holds them)."""
    importing = queries.active_job(session, project_id)
    if importing is not None and importing.kind == "import":
        raise Conflict(f"an import (job {importing.id}) is {importing.state} in this project; "
                       "upload once it has ended")
    taken = set(queries.image_ids_by_name(session, project_id))
    clashes = sorted(image.name for image in checked if image.name in taken)
    if clashes:
        raise Conflict(f"the project already has images named {', '.join(clashes[:5])}")
    rows = [Image(project_id=project_id, name=i.name, width=i.width, height=i.height,
                  seq=0, taken_at=i.taken_at, sha256=i.sha256) for i in checked]
    session.add_all(rows)
    try:
        session.flush()
    except IntegrityError as exc:  # a racing upload took a name between the check and here
        session.rollback()
        raise Conflict("another upload stored images with these names first") from exc
    renumber(session, project_id)
    return rows


def _reveal(store: Store, project_id: int, staging: Path, rows: list[Image]) -> list[str]:
    """Put the staged files in the store; their keys. The rows are flushed, so a file already there
    under one of these names has no row: an orphan of a crashed upload, replaced (the reconciler
    removes the others)."""
    revealed = []
    try:
        for row in rows:
            thumb, target = thumb_key(project_id, row.id), image_key(project_id, row.name)
            store.put(thumb, staging / uploads.THUMBS / row.name)
            revealed.append(thumb)
            store.put(target, staging / row.name)
            revealed.append(target)
    except BaseException:
        for key in revealed:
            store.remove(key)
        raise
    return revealed


def renumber(session: Session, project_id: int) -> None:
    """seq = capture order: EXIF time when every image has one, else file-name order."""
    rows = queries.images(session, project_id)
    by_time = all(row.taken_at for row in rows)
    for seq, row in enumerate(sorted(rows, key=lambda r: ((r.taken_at or "") if by_time else "", r.name))):
        row.seq = seq
    session.flush()


def make_thumbnail(source: Path, target: Path) -> None:
    """A small JPEG preview of a stored image."""
    with PIL.Image.open(source) as img:
        img.draft("RGB", uploads.THUMBNAIL_SIZE)
        uploads.save_thumbnail(img, target)


def thumbnail(store: Store, image: Image) -> Blob:
    """The image's thumbnail, made again if it is missing (e.g. after an import)."""
    key = thumb_key(image.project_id, image.id)
    if not store.exists(key):
        with store.staging(image.project_id, prefix="thumb-") as scratch:
            store.fetch(image_key(image.project_id, image.name), scratch / "image")
            make_thumbnail(scratch / "image", scratch / "thumb.jpg")
            store.put(key, scratch / "thumb.jpg")
    return store.blob(key)


def original(store: Store, image: Image) -> Blob:
    return store.blob(image_key(image.project_id, image.name))
