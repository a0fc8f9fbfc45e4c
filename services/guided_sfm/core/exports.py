"""A workspace's largest model as files for other tools: a COLMAP binary model (zipped), PLY."""

from __future__ import annotations

import zipfile
from pathlib import Path

from guided_sfm.core.errors import EmptyModel
from guided_sfm.core.workspace import Workspace


def export_colmap_zip(workspace: Workspace, out_file: Path) -> None:
    """A zip of the largest model's cameras.bin, images.bin and points3D.bin."""
    model_dir = workspace.model_dir()
    if not model_dir.is_dir():
        raise EmptyModel(f"{workspace.root} has no sparse model to export")
    with zipfile.ZipFile(out_file, "w", zipfile.ZIP_DEFLATED) as archive:
        for name in ("cameras.bin", "images.bin", "points3D.bin"):
            archive.write(model_dir / name, name)


def export_ply(workspace: Workspace, out_file: Path) -> None:
    """Binary PLY of the largest model's points with colours."""
    models = workspace.load_models()
    if not models:
        raise EmptyModel(f"{workspace.root} has no sparse model to export")
    models[0].export_PLY(out_file)
