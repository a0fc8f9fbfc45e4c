"""Export a version (COLMAP binary or text zip, PLY points, nerfstudio zip) into a temporary file."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from guided_sfm.core import exports
from guided_sfm.core.errors import InvalidInput
from guided_sfm.core.workspace import Workspace
from guided_sfm.db.models import Version
from guided_sfm.storage import Store

FORMATS = {"colmap": (".zip", "application/zip"), "ply": (".ply", "application/octet-stream"),
           "colmap_text": (".zip", "application/zip"), "nerfstudio": (".zip", "application/zip")}
WRITERS = {"colmap": exports.export_colmap_zip, "ply": exports.export_ply,
           "colmap_text": exports.export_colmap_text, "nerfstudio": exports.export_nerfstudio}


def export(store: Store, version: Version, fmt: str) -> tuple[Path, str, str]:
    """(temporary file the caller removes, download name, media type)."""
    if fmt not in FORMATS:
        raise InvalidInput(f"unknown export format {fmt!r}; choose one of {sorted(FORMATS)}")
    suffix, media_type = FORMATS[fmt]
    handle, name = tempfile.mkstemp(suffix=suffix, prefix="export-")
    os.close(handle)
    out = Path(name)
    try:
        _write(store, version, fmt, out)
    except BaseException:
        out.unlink(missing_ok=True)
        raise
    return out, f"version-{version.id}{suffix}", media_type


def _write(store: Store, version: Version, fmt: str, out: Path) -> None:
    """The version read from the store (fetched into a scratch dir if need be); nerfstudio also
    takes the images its frames name."""
    with store.reading(version.path) as root:
        workspace = Workspace(root)
        if fmt != "nerfstudio":
            WRITERS[fmt](workspace, out)
            return
        with store.staging(version.project_id, prefix="export-") as scratch:
            names = workspace.image_ids()
            exports.export_nerfstudio(workspace, out, store.images_for(version.project_id, names, scratch))
