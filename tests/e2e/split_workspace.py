"""A real COLMAP workspace with two models, made from a reconstruction the served app computed: a
capture-order stretch of its cameras is taken out of the model into a second one, in a frame of its
own (turned, scaled and shifted, as a separate model of the mapper would be). Zipped as the import
route takes it (database.db, sparse/0/, sparse/1/, images/)."""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np
import pycolmap

# The second model's own frame: its poses as the mapper could have left them.
SIDE_FRAME = pycolmap.Sim3d(0.7, pycolmap.Rotation3d(np.array([0.0, 0.0, np.sin(0.35), np.cos(0.35)])),
                            np.array([3.0, -2.0, 0.5]))


def first_version_dir(data_dir: Path, project_id: int) -> Path:
    """The project's first version in the server's artifact store (the oldest published one)."""
    found = sorted((data_dir / "artifacts" / "projects" / str(project_id) / "versions").glob("*/sparse/0"),
                   key=lambda p: p.parent.parent.stat().st_mtime)
    assert found, f"no published version of project {project_id} under {data_dir}"
    return found[0].parent.parent


def split_models(model_dir: Path, side_names: set[str], out: Path) -> None:
    """sparse/0: the model without side_names; sparse/1: those alone, moved into SIDE_FRAME."""
    for index, keep in ((0, lambda n: n not in side_names), (1, lambda n: n in side_names)):
        model = pycolmap.Reconstruction(model_dir)
        for image_id in list(model.reg_image_ids()):
            if not keep(model.image(image_id).name):
                model.deregister_frame(model.image(image_id).frame_id)
        if index == 1:
            model.transform(SIDE_FRAME)
        target = out / "sparse" / str(index)
        target.mkdir(parents=True)
        model.write(target)


def split_workspace_zip(version_dir: Path, images_dir: Path, side_names: set[str], out: Path) -> Path:
    """The zip of a workspace whose model is split in two."""
    work = out / "split"
    split_models(version_dir / "sparse" / "0", side_names, work)
    archive = out / "split.zip"
    with zipfile.ZipFile(archive, "w") as z:
        z.write(version_dir / "database.db", "database.db")
        for path in sorted((work / "sparse").rglob("*")):
            if path.is_file():
                z.write(path, str(path.relative_to(work)))
        for path in sorted(images_dir.iterdir()):
            z.write(path, f"images/{path.name}")
    return archive
