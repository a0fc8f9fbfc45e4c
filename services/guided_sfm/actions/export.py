"""Export a version as a COLMAP model zip or a PLY point cloud, into a temporary file."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from guided_sfm.core import exports
from guided_sfm.core.errors import InvalidInput
from guided_sfm.core.workspace import Workspace
from guided_sfm.db.models import Version
from guided_sfm.storage import ArtifactStore

FORMATS = {"colmap": (".zip", "application/zip"), "ply": (".ply", "application/octet-stream"),
           "colmap_text": (".zip", "application/zip"), "nerfstudio": (".zip", "application/zip")}
WRITERS = {"colmap": exports.export_colmap_zip, "ply": exports.export_ply,
           "colmap_text": exports.export_colmap_text, "nerfstudio": exports.export_nerfstudio}


def export(store: ArtifactStore, version: Version, fmt: str) -> tuple[Path, str, str]:
    """(temporary file the caller removes, download name, media type)."""
    if fmt not in FORMATS:
        raise InvalidInput(f"unknown export format {fmt!r}; choose one of {sorted(FORMATS)}")
    suffix, media_type = FORMATS[fmt]
    handle, name = tempfile.mkstemp(suffix=suffix, prefix="export-")
    os.close(handle)
    out = Path(name)
    try:
        WRITERS[fmt](Workspace(store.version_dir(version.path)), out)
    except BaseException:
        out.unlink(missing_ok=True)
        raise
    return out, f"version-{version.id}{suffix}", media_type
