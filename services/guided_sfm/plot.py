"""A PNG of a top-down scene (points, cameras, frustum triangles) for people to look at."""

from __future__ import annotations

from pathlib import Path

import matplotlib
import PIL.Image  # noqa: F401  (before pycolmap: see the Pillow pitfall in cli.py)

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from guided_sfm.core.geometry import view_extent  # noqa: E402
from guided_sfm.core.rule.frustum import frustum_vertices  # noqa: E402
from guided_sfm.core.types import TopDownScene  # noqa: E402


def plot_scene(scene: TopDownScene, out_file: Path,
               highlight: set[int] = frozenset()) -> tuple[float, float, float, float] | None:
    """Draw the scene seen from above, framed on the cameras and the points near them (as the
    editor's Fit), with the capture order as a line; highlighted image ids are drawn in red.
    Returns the framed (x0, y0, x1, y1)."""
    fig, ax = plt.subplots(figsize=(10, 8), dpi=100)
    if len(scene.points_xy):
        ax.scatter(scene.points_xy[:, 0], scene.points_xy[:, 1], s=0.3, c="0.6", linewidths=0)
    placed = sorted((c for c in scene.cameras if c.x is not None), key=lambda c: c.seq)
    if placed:
        _draw_cameras(ax, placed, highlight)
    extent = _frame(ax, scene, placed)
    ax.set_title(f"{len(placed)} of {len(scene.cameras)} cameras in the largest model")
    fig.savefig(out_file, bbox_inches="tight")
    plt.close(fig)
    return extent


def _draw_cameras(ax, placed: list, highlight: set[int]) -> None:
    tri = frustum_vertices(np.array([c.x for c in placed]), np.array([c.y for c in placed]),
                           np.array([c.yaw_deg for c in placed]), np.array([c.fov_deg for c in placed]),
                           np.array([c.range for c in placed]))
    ax.plot([c.x for c in placed], [c.y for c in placed], "-", lw=0.6, color="0.45")  # capture order
    for camera, triangle in zip(placed, tri, strict=True):
        colour = "tab:red" if camera.image_id in highlight else "tab:blue"
        ax.fill(triangle[:, 0], triangle[:, 1], alpha=0.08, color=colour)
        ax.plot(camera.x, camera.y, "o", ms=3, color=colour)
        ax.annotate(str(camera.seq), (camera.x, camera.y), fontsize=6)


def _frame(ax, scene: TopDownScene, placed: list) -> tuple[float, float, float, float] | None:
    """Limit the axes to the view extent the editor's Fit uses (padded by 5%), equal aspect."""
    ranges = [c.range for c in placed if c.range]
    extent = view_extent(np.array([[c.x, c.y] for c in placed]).reshape(-1, 2), scene.points_xy,
                         float(np.median(ranges)) if ranges else 0.0)
    ax.set_aspect("equal", adjustable="datalim")
    if extent is None:
        return None
    x0, y0, x1, y1 = extent
    pad = 0.05 * max(x1 - x0, y1 - y0)
    ax.set_xlim(x0 - pad, x1 + pad)
    ax.set_ylim(y0 - pad, y1 + pad)
    return extent
