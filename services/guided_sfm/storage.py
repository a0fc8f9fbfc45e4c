"""ArtifactStore: per-project images and immutable version directories, published atomically.

Layout under the root: `projects/{pid}/images/` (the uploaded files, shared by every version),
`projects/{pid}/thumbs/{image_id}.jpg`, `projects/{pid}/versions/{key}/` (one COLMAP workspace
per version, never modified once published), `projects/{pid}/uploads/` (an import's zip until its
job reads it) and `projects/{pid}/tmp/` (work in progress).
"""

from __future__ import annotations

import os
import shutil
import tempfile
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path


class ArtifactStore:
    def __init__(self, root: Path) -> None:
        self.root = Path(root)

    def project_dir(self, project_id: int) -> Path:
        return self.root / "projects" / str(project_id)

    def images_dir(self, project_id: int) -> Path:
        return self.project_dir(project_id) / "images"

    def image_file(self, project_id: int, name: str) -> Path:
        return self.images_dir(project_id) / name

    def thumbnail(self, project_id: int, image_id: int) -> Path:
        return self.project_dir(project_id) / "thumbs" / f"{image_id}.jpg"

    def uploads_dir(self, project_id: int) -> Path:
        """Uploads kept for a queued job (an import's zip); made on first use."""
        path = self.project_dir(project_id) / "uploads"
        path.mkdir(parents=True, exist_ok=True)
        return path

    def version_dir(self, relative: str) -> Path:
        return self.root / relative

    @contextmanager
    def staging(self, project_id: int, prefix: str = "work-") -> Iterator[Path]:
        """A private temp dir on the same file system as the versions (so publish can rename it)."""
        tmp_root = self.project_dir(project_id) / "tmp"
        tmp_root.mkdir(parents=True, exist_ok=True)
        path = Path(tempfile.mkdtemp(prefix=prefix, dir=tmp_root))
        try:
            yield path
        finally:
            shutil.rmtree(path, ignore_errors=True)

    def publish(self, project_id: int, staged: Path) -> str:
        """Move a finished workspace into place in one rename; returns its relative location."""
        versions = self.project_dir(project_id) / "versions"
        versions.mkdir(parents=True, exist_ok=True)
        target = versions / uuid.uuid4().hex
        os.replace(staged, target)
        return str(target.relative_to(self.root))

    def discard(self, relative: str) -> None:
        shutil.rmtree(self.root / relative, ignore_errors=True)

    def delete_project(self, project_id: int) -> None:
        shutil.rmtree(self.project_dir(project_id), ignore_errors=True)


def link_file(source: Path | str, target: Path | str) -> None:
    """Hard-link a file (versions share unchanged files); a copy across devices."""
    try:
        os.link(source, target)
    except OSError:
        shutil.copy2(source, target)


def link_tree(source: Path, target: Path) -> None:
    """Copy a directory tree as hard links (versions share unchanged files); copies across devices."""
    shutil.copytree(source, target, copy_function=link_file, dirs_exist_ok=True)
