"""Render a layout to disk: JPEG images, z-depth maps and truth.json."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import PIL.Image

from guided_sfm.core.errors import InvalidInput
from guided_sfm.core.types import Progress, no_progress
from guided_sfm.sample.geometry import qvec_from_matrix
from guided_sfm.sample.layouts import LAYOUT_BUILDERS, Layout
from guided_sfm.sample.raycast import render

JPEG_QUALITY = 95


def build_layout(layout: str, seed: int) -> Layout:
    """The named layout's scene, camera and poses; raises InvalidInput for an unknown name."""
    if layout not in LAYOUT_BUILDERS:
        raise InvalidInput(f"unknown layout {layout!r}; choose one of {sorted(LAYOUT_BUILDERS)}")
    return LAYOUT_BUILDERS[layout](seed)


def to_photo(rgb: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Camera response: per-image exposure, gamma, mild sensor noise; uint8."""
    exposure = 1.0 + 0.04 * rng.standard_normal()
    img = np.clip(rgb * exposure, 0, 1) ** (1 / 1.2) * 255
    img += rng.normal(0, 1.5, img.shape)
    return np.clip(img + 0.5, 0, 255).astype(np.uint8)


def _write_view(spec, pose, rank: int, seed: int, out_dir: Path) -> dict:
    """Render one view into images/ and depth/; its truth record."""
    r, t = pose
    rgb, depth = render(spec.scene, spec.camera, (r, t))
    photo = to_photo(rgb, np.random.default_rng([seed, rank, 7]))
    name = f"{rank:04d}.jpg"
    PIL.Image.fromarray(photo).save(out_dir / "images" / name, quality=JPEG_QUALITY)
    np.save(out_dir / "depth" / f"{rank:04d}.npy", depth)
    return {"name": name, "center": [float(v) for v in -r.T @ t], "qvec": qvec_from_matrix(r),
            "tvec": [float(v) for v in t]}


def write_sample(out_dir: Path, layout: str, seed: int = 0, progress: Progress = no_progress,
                 resolution: tuple[int, int] | None = None, views: int | None = None) -> Path:
    """Render every view of a layout into out_dir (images/, depth/, truth.json); returns out_dir.

    `resolution` (width, height) renders with the layout's camera scaled to it (the same field of
    view); `views` renders only the first that many views in capture order. Each view is seeded by
    its rank, so a slice's images are the whole layout's first images.
    """
    spec = build_layout(layout, seed)
    if resolution is not None:
        spec.camera = spec.camera.scaled(*resolution)
    if views is not None:
        spec.poses = spec.poses[:views]
    out_dir = Path(out_dir)
    (out_dir / "images").mkdir(parents=True, exist_ok=True)
    (out_dir / "depth").mkdir(exist_ok=True)
    records = []
    n = len(spec.poses)
    progress("render", 0.0)
    for i, pose in enumerate(spec.poses):
        records.append(_write_view(spec, pose, i, seed, out_dir))
        progress("render", (i + 1) / n)
    truth = {
        "units": "m",
        "up": [0, 0, 1],
        "layout": layout,
        "seed": seed,
        "camera": spec.camera.to_dict(),
        "images": records,
    }
    (out_dir / "truth.json").write_text(json.dumps(truth, indent=1))
    return out_dir
