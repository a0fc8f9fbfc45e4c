"""What a job's action receives (JobContext) and returns (Produced): plain values, no Celery."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from sqlalchemy.orm import Session, sessionmaker

from guided_sfm.core.sfm import CancelToken, RunContext, SfmOptions
from guided_sfm.core.types import Progress
from guided_sfm.db.models import Job
from guided_sfm.settings import Settings
from guided_sfm.storage import Store

SFM_PARAMS = ("camera_model", "matcher", "mapper", "max_image_size")


def sfm_options(params: dict[str, Any], **extra: Any) -> SfmOptions:
    """The SfM options a job's params choose, over the defaults (max_image_size 0: COLMAP's own)."""
    chosen = {k: v for k, v in params.items() if k in SFM_PARAMS and v}
    if params.get("max_image_size") == 0:
        chosen["max_image_size"] = None
    return SfmOptions(**chosen, **extra)


@dataclass(frozen=True)
class JobContext:
    settings: Settings
    store: Store
    sessions: sessionmaker[Session]
    job: Job  # a detached snapshot of the row as it was claimed
    progress: Progress
    cancel: CancelToken
    scratch: Path  # the job's own dir: its inputs are fetched here, its output staged; emptied after

    def options(self) -> SfmOptions:
        """The job's SfM options over the defaults, with the configured thread count."""
        return sfm_options(self.job.params, num_threads=self.settings.threads)

    def run(self) -> RunContext:
        """The job's options, progress reports and cancellation, as the core's steps take them."""
        return RunContext(self.options(), self.progress, self.cancel)

    def images_dir(self, names: Iterable[str]) -> Path:
        """A folder holding these images of the project (fetched into the scratch dir if need be)."""
        return self.store.images_for(self.job.project_id, names, self.scratch)

    def checkout(self, version: str) -> Path:
        """A published version's workspace to read (fetched into the scratch dir if need be)."""
        return self.store.checkout(version, self.scratch)


@dataclass
class NewImage:
    name: str
    width: int
    height: int
    taken_at: str | None = None
    sha256: str | None = None


@dataclass
class Produced:
    """A finished workspace in staging, and what its version row should say."""

    workspace: Path
    kind: str
    message: str
    parent_id: int | None
    stats: dict[str, int]
    edits: dict[str, Any] | None = None
    deleted_pairs: list[tuple[int, int, tuple[str, ...]]] = field(default_factory=list)  # REST ids
    new_images: list[NewImage] = field(default_factory=list)  # import: files in `images_from`
    images_from: Path | None = None
    reuse_from: tuple[str, ...] = ()  # published versions whose unchanged files the new one may share
    timings: dict[str, Any] | None = None  # StageClock.report() of the job, stored on its row
