"""The data-dir backend (the embedded default): keys are paths under the root; a version is a
folder published with one rename, so a crashed job leaves no half version."""

from __future__ import annotations

import os
import shutil
import tempfile
import uuid
from collections.abc import Iterable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

from guided_sfm.storage.base import (
    Blob,
    Store,
    StoreUnavailable,
    image_key,
    link_file,
    link_tree,
    project_prefix,
)


class ArtifactStore(Store):
    def __init__(self, root: Path) -> None:
        self.root = Path(root)

    # -- the layout as paths (the data dir's own; tests and the reconciler of old read them) ------

    def project_dir(self, project_id: int) -> Path:
        return self.root / project_prefix(project_id)

    def images_dir(self, project_id: int) -> Path:
        return self.project_dir(project_id) / "images"

    def image_file(self, project_id: int, name: str) -> Path:
        return self.root / image_key(project_id, name)

    def thumbnail(self, project_id: int, image_id: int) -> Path:
        return self.project_dir(project_id) / "thumbs" / f"{image_id}.jpg"

    def uploads_dir(self, project_id: int) -> Path:
        """Uploads kept for a queued job (an import's zip); made on first use."""
        path = self.project_dir(project_id) / "uploads"
        path.mkdir(parents=True, exist_ok=True)
        return path

    def version_dir(self, relative: str) -> Path:
        return self.root / relative

    # -- single files -----------------------------------------------------------------------------

    def put(self, key: str, source: Path) -> None:
        target = self.root / key
        target.parent.mkdir(parents=True, exist_ok=True)
        os.replace(source, target)  # staging is on the same file system: one rename

    def fetch(self, key: str, target: Path) -> None:
        target.parent.mkdir(parents=True, exist_ok=True)
        link_file(self.root / key, target)

    def exists(self, key: str) -> bool:
        return (self.root / key).is_file()

    def remove(self, key: str) -> None:
        path = self.root / key
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path, ignore_errors=True)
        else:
            path.unlink(missing_ok=True)

    def children(self, prefix: str) -> list[str]:
        folder = self.root / prefix
        return sorted(path.name for path in folder.iterdir()) if folder.is_dir() else []

    def changed(self, key: str) -> float | None:
        try:
            return (self.root / key).lstat().st_mtime  # a revealed file keeps its staging time
        except FileNotFoundError:
            return None

    def blob(self, key: str) -> Blob:
        path = self.root / key
        return Blob(path.stat().st_size, path=path)

    def prepare(self) -> None:
        """The root, made for a new data dir (at the API's start; never by check())."""
        self.root.mkdir(parents=True, exist_ok=True)

    def check(self) -> None:
        """A file made and removed at the root. A missing root is not made: a volume that is not
        mounted (or went away) has none, and a folder made in its place would read as ready."""
        if not self.root.is_dir():
            raise StoreUnavailable("artifact store unavailable (the data dir has no artifacts folder)")
        try:
            with tempfile.NamedTemporaryFile(dir=self.root, prefix=".ready-"):
                pass
        except OSError as exc:  # no paths in the reason: readiness answers anyone
            raise StoreUnavailable(f"artifact store unavailable (the data dir's artifacts folder takes "
                                   f"no file: {type(exc).__name__})") from exc

    # -- versions ---------------------------------------------------------------------------------

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

    def publish(self, project_id: int, staged: Path, reuse_from: Sequence[str] = ()) -> str:
        """Move a finished workspace into place in one rename (it shares files by hard links)."""
        versions = self.project_dir(project_id) / "versions"
        versions.mkdir(parents=True, exist_ok=True)
        target = versions / uuid.uuid4().hex
        os.replace(staged, target)
        return str(target.relative_to(self.root))

    def checkout(self, version: str, scratch: Path, only: Sequence[str] | None = None) -> Path:
        return self.version_dir(version)  # read in place: a published folder never changes

    @contextmanager
    def reading(self, version: str, only: Sequence[str] | None = None) -> Iterator[Path]:
        yield self.version_dir(version)

    def fetch_member(self, version: str, member: str, target: Path) -> bool:
        source = self.version_dir(version) / member
        if not source.is_file():
            return False
        target.parent.mkdir(parents=True, exist_ok=True)
        link_file(source, target)
        return True

    def copy_version(self, project_id: int, version: str) -> str:
        with self.staging(project_id, prefix="restore-") as staging:
            link_tree(self.version_dir(version), staging / "workspace")
            return self.publish(project_id, staging / "workspace")

    def images_for(self, project_id: int, names: Iterable[str], scratch: Path) -> Path:
        return self.images_dir(project_id)

    def image_location(self, project_id: int) -> str:
        return str(self.images_dir(project_id))
