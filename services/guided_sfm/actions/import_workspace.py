"""Import an existing COLMAP workspace (zip of database.db, sparse/0/, images/) as a first version."""

from __future__ import annotations

import zipfile
from pathlib import Path, PurePosixPath

from guided_sfm.actions import uploads
from guided_sfm.actions.context import JobContext, NewImage, Produced
from guided_sfm.core.errors import InvalidInput
from guided_sfm.core.workspace import Workspace
from guided_sfm.errors import BadUpload

REQUIRED = ("database.db", "sparse/0/")


def check_archive(path: Path, limit: int) -> None:
    """Refuse an unsafe or incomplete workspace zip before a job is queued (the API calls this)."""
    with uploads.open_zip(path) as archive:
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
    upload = context.store.root / context.job.params["upload"]
    try:
        images = _extract(upload, work, context.settings.max_upload_bytes)
    finally:
        upload.unlink(missing_ok=True)
    workspace = Workspace(work)
    workspace.write_meta({"image_dir": str(context.images_dir()), "imported": True})
    names = set(workspace.image_ids())
    missing = sorted(names - {image.name for image in images})
    if missing:
        raise InvalidInput(f"images/ lacks {len(missing)} images of database.db, e.g. {missing[0]}")
    context.progress("scene", 0.5)
    workspace.write_scene()
    stats = workspace.stats()
    message = f"imported a COLMAP workspace: {stats['num_registered']} of {stats['num_images']} registered"
    return Produced(work, "import", message, None, stats, new_images=images, images_from=work / "images")


def _extract(upload: Path, work: Path, limit: int) -> list[NewImage]:
    budget = uploads.Budget(limit)
    images = []
    with uploads.open_zip(upload) as archive:
        for info, path in _members(archive, budget):
            if path.parts[0] == "images" and len(path.parts) > 2:
                raise BadUpload(f"{info.filename}: images/ must be flat (no sub-folders)")
            uploads.extract(archive, info, work / path, budget)
            if path.parts[0] == "images":
                name = uploads.image_name(path.name, "zip entry")
                images.append(uploads.check_image(work / path, name))
    return images
