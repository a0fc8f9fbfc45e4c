"""A workspace's largest model as files for other tools: a COLMAP model (binary or text, zipped),
PLY, and nerfstudio's data format (zipped with the images it names)."""

from __future__ import annotations

import json
import tempfile
import zipfile
from pathlib import Path

from guided_sfm.core import nerfstudio
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


def _largest(workspace: Workspace):
    models = workspace.load_models()
    if not models:
        raise EmptyModel(f"{workspace.root} has no sparse model to export")
    return models[0]


def export_colmap_text(workspace: Workspace, out_file: Path) -> None:
    """A zip of the largest model's cameras.txt, images.txt and points3D.txt."""
    model = _largest(workspace)
    with tempfile.TemporaryDirectory(prefix="colmap-text-") as scratch:
        model.write_text(scratch)
        with zipfile.ZipFile(out_file, "w", zipfile.ZIP_DEFLATED) as archive:
            for name in ("cameras.txt", "images.txt", "points3D.txt"):
                archive.write(Path(scratch) / name, name)


def export_nerfstudio(workspace: Workspace, out_file: Path, image_dir: Path | None = None) -> None:
    """A zip of transforms.json (one frame per registered camera of the largest model), the
    images it names under images/ (from image_dir, else where the workspace records them), and
    sparse_pc.ply."""
    model = _largest(workspace)
    document = nerfstudio.transforms(model)
    image_dir = image_dir or workspace.image_dir()
    with tempfile.TemporaryDirectory(prefix="nerfstudio-") as scratch:
        ply = Path(scratch) / "sparse_pc.ply"
        nerfstudio.write_points_ply(model, ply)
        with zipfile.ZipFile(out_file, "w", zipfile.ZIP_DEFLATED) as archive:
            archive.writestr("transforms.json", json.dumps(document, indent=2))
            archive.write(ply, "sparse_pc.ply")
            for frame in document["frames"]:  # JPEG/PNG are compressed already
                name = frame["file_path"].removeprefix("images/")
                archive.write(image_dir / name, frame["file_path"], compress_type=zipfile.ZIP_STORED)
