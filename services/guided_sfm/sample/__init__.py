"""Rendered sample scenes with repeated identical objects and ground truth (pure numpy + Pillow)."""

from __future__ import annotations

from pathlib import Path

from guided_sfm.core.types import Progress, no_progress
from guided_sfm.sample import writer
from guided_sfm.sample.hall import HALL_LAYOUTS
from guided_sfm.sample.layouts import LAYOUT_BUILDERS
from guided_sfm.sample.objects import OBJECT_LAYOUTS
from guided_sfm.sample.split import SPLIT_LAYOUTS

LAYOUT_BUILDERS.update(OBJECT_LAYOUTS)  # the writer renders any layout registered here
LAYOUT_BUILDERS.update(HALL_LAYOUTS)
LAYOUT_BUILDERS.update(SPLIT_LAYOUTS)
LAYOUTS = dict(LAYOUT_BUILDERS)
DEFAULT_LAYOUT = "murals"


def write_sample(
    out_dir: Path, layout: str = DEFAULT_LAYOUT, seed: int = 0, progress: Progress = no_progress,
    resolution: tuple[int, int] | None = None, views: int | None = None,
) -> Path:
    """Render a layout's images, depth maps and truth.json into out_dir; returns out_dir.
    `resolution` scales the layout's camera (same field of view); `views` keeps the first views."""
    return writer.write_sample(out_dir, layout, seed, progress, resolution, views)


__all__ = ["DEFAULT_LAYOUT", "LAYOUTS", "write_sample"]
