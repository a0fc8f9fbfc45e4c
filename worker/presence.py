"""The filesystem broker has no broadcast to ping workers: each worker's sweeper touches a file."""

from __future__ import annotations

from pathlib import Path

from guided_sfm.settings import Settings

PRESENCE_PERIODS = 5  # a worker silent for this many sweep periods (its sweeper backs off to 4) is gone


def presence_dir(settings: Settings) -> Path:
    return settings.broker_dir / "workers"


def touch_presence(settings: Settings, name: str) -> None:
    folder = presence_dir(settings)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / name).touch()
