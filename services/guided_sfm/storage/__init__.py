"""Every project file goes through the artifact store: `open_store(settings)` picks the backend
(GUIDED_SFM_ARTIFACTS_URL unset: the data dir; s3://BUCKET/PREFIX: S3). See base.py for the keys."""

from __future__ import annotations

from pathlib import Path
from typing import Protocol

from guided_sfm.storage.base import (
    Blob,
    Store,
    StoreUnavailable,
    UnpublishedVersion,
    image_key,
    link_file,
    link_tree,
    project_prefix,
    thumb_key,
    upload_key,
)
from guided_sfm.storage.local import ArtifactStore

__all__ = ["ArtifactStore", "Blob", "Store", "UnpublishedVersion", "image_key", "link_file", "link_tree",
           "open_store", "project_prefix", "StoreUnavailable", "thumb_key", "upload_key"]


class StoreSettings(Protocol):
    """What the store reads of guided_sfm.settings.Settings (the store imports no settings)."""

    artifacts_dir: Path
    artifacts_url: str
    s3_endpoint_url: str


def open_store(settings: StoreSettings) -> Store:
    """The store the settings name; boto3 is imported only when S3 is configured."""
    if not settings.artifacts_url:
        return ArtifactStore(settings.artifacts_dir)
    from guided_sfm.storage.s3 import S3Store

    return S3Store.from_url(settings.artifacts_url, settings.s3_endpoint_url)
