"""The artifact store's interface (design.md v1.1, "Storage for workers on several hosts"): the keys
of a project's files and versions, and what every backend does with them.

Keys, the same in every backend: `projects/{pid}/images/{name}` (uploaded files, shared by every
version), `projects/{pid}/thumbs/{image_id}.jpg`, `projects/{pid}/uploads/{token}.zip` (an
import's zip until its job reads it) and `projects/{pid}/versions/{vid}/` (one COLMAP workspace per
version, never changed once published). A process works on local copies in its scratch dir
(`staging`) and publishes a finished workspace as a new version in one step that readers see whole
or not at all: a rename in the data dir, a manifest written last in S3.
"""

from __future__ import annotations

import logging
import os
import shutil
from abc import ABC, abstractmethod
from collections.abc import Iterable, Iterator, Sequence
from contextlib import AbstractContextManager, contextmanager
from dataclasses import dataclass
from pathlib import Path

log = logging.getLogger(__name__)


def project_prefix(project_id: int) -> str:
    return f"projects/{project_id}"


def image_key(project_id: int, name: str) -> str:
    return f"{project_prefix(project_id)}/images/{name}"


def thumb_key(project_id: int, image_id: int) -> str:
    return f"{project_prefix(project_id)}/thumbs/{image_id}.jpg"


def upload_key(project_id: int, token: str) -> str:
    return f"{project_prefix(project_id)}/uploads/{token}.zip"


class UnpublishedVersion(FileNotFoundError):
    """A version key with no manifest: never published, or still being published."""


class StoreUnavailable(Exception):
    """The store did not answer as a store does (unreachable, refusing, overloaded, denying
    access): the call read or changed nothing it reports, and may be tried again later."""


@dataclass(frozen=True)
class Blob:
    """A stored file as the API sends it: a local file, or a stream of chunks of a known size."""

    size: int
    path: Path | None = None
    chunks: Iterable[bytes] | None = None


class Store(ABC):
    """One interface, two backends: the data dir (local.ArtifactStore) and S3 (s3.S3Store)."""

    # time.monotonic() of the last call the store answered (None: none yet, or a store that is
    # never unavailable); a job's wait for the store counts from it (actions/store_wait.py)
    answered_at: float | None = None

    # -- single files by key ----------------------------------------------------------------------

    @abstractmethod
    def put(self, key: str, source: Path) -> None:
        """Store a local file under key, replacing what was there (the source may be moved)."""

    @abstractmethod
    def fetch(self, key: str, target: Path) -> None:
        """A local copy of the file at key (FileNotFoundError when there is none)."""

    @abstractmethod
    def exists(self, key: str) -> bool: ...

    @abstractmethod
    def remove(self, key: str) -> None:
        """The file at key and everything under key + "/"; nothing when there is none."""

    @abstractmethod
    def children(self, prefix: str) -> list[str]:
        """Names one level under prefix (files and folders), sorted; costs that level only."""

    @abstractmethod
    def changed(self, key: str) -> float | None:
        """When the file or folder at key last changed (epoch seconds), None when there is none.
        A folder's time: in the data dir its own (a published version keeps its staging time), on
        S3 its newest object's (a version still uploading looks young)."""

    @abstractmethod
    def blob(self, key: str) -> Blob:
        """The file at key to send (FileNotFoundError when there is none)."""

    # -- versions and scratch ---------------------------------------------------------------------

    @abstractmethod
    def staging(self, project_id: int, prefix: str = "work-") -> AbstractContextManager[Path]:
        """A private scratch dir, removed with everything in it when the block ends."""

    @abstractmethod
    def publish(self, project_id: int, staged: Path, reuse_from: Sequence[str] = ()) -> str:
        """Publish a finished workspace as a new version; returns its key (kept on the version's row).
        Files identical to one of `reuse_from`'s (published versions) may be shared with it."""

    @abstractmethod
    def checkout(self, version: str, scratch: Path, only: Sequence[str] | None = None) -> Path:
        """A readable workspace of a published version (its files, or those starting with one of
        `only`), in scratch when it must be copied; never written to."""

    @abstractmethod
    def fetch_member(self, version: str, member: str, target: Path) -> bool:
        """One file of a published version copied to target; False when the version has none."""

    @abstractmethod
    def copy_version(self, project_id: int, version: str) -> str:
        """A new version with the same content (restore); nothing is copied byte for byte."""

    @abstractmethod
    def images_for(self, project_id: int, names: Iterable[str], scratch: Path) -> Path:
        """A folder holding the project's images of these names (fetched into scratch if need be)."""

    @abstractmethod
    def image_location(self, project_id: int) -> str:
        """Where the project's images are, as a workspace records it (informative only)."""

    @abstractmethod
    def check(self) -> None:
        """Raise StoreUnavailable unless the store answers and takes a write (readiness); quick."""

    @abstractmethod
    def prepare(self) -> None:
        """Make what the store needs before its first use (at the API's start, never in check())."""

    def clear_stale_scratch(self) -> int:
        """Scratch dirs left by processes that died mid-job; the count removed."""
        return 0

    # -- shared helpers ---------------------------------------------------------------------------

    @contextmanager
    def reading(self, version: str, only: Sequence[str] | None = None) -> Iterator[Path]:
        """A published version to read for the length of the block (a request, a check)."""
        with self.staging(_project_of(version), prefix="read-") as scratch:
            yield self.checkout(version, scratch, only)

    def discard(self, version: str) -> None:
        self.remove(version)

    def delete_project(self, project_id: int) -> None:
        self.remove(project_prefix(project_id))

    def remove_committed(self, keys: Iterable[str]) -> None:
        """Remove the files of rows whose deletion is already committed: a store away now cannot
        undo the commit, so what it keeps is left to the reconciler (orphans once past the grace)."""
        for key in keys:
            try:
                self.remove(key)
            except StoreUnavailable as exc:  # the store is away: the rest waits for it too
                log.warning("%s and the other files of deleted rows kept for the reconciler: %s", key, exc)
                return


def _project_of(version: str) -> int:
    """The project id in a version key `projects/{pid}/versions/{vid}`."""
    return int(version.split("/")[1])


def link_file(source: Path | str, target: Path | str) -> None:
    """Hard-link a file (versions share unchanged files); a copy across devices."""
    try:
        os.link(source, target)
    except OSError:
        shutil.copy2(source, target)


def link_tree(source: Path, target: Path) -> None:
    """Copy a directory tree as hard links (versions share unchanged files); copies across devices."""
    shutil.copytree(source, target, copy_function=link_file, dirs_exist_ok=True)
