"""A PNG of a top-down scene (points, cameras, frustum triangles) for people to look at."""

from __future__ import annotations

from pathlib import Path

import matplotlib
import PIL.Image  # noqa: F401  (before pycolmap: see the Pillow pitfall in cli.py)

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from guided_sfm.core.rule.frustum import frustum_vertices  # noqa: E402
from guided_sfm.core.types import TopDownScene  # noqa: E402


def plot_scene(scene: TopDownScene, out_file: Path, highlight: set[int] = frozenset()) -> None:
    """Draw the scene seen from above; highlighted image ids are drawn in red."""
    fig, ax = plt.subplots(figsize=(10, 8), dpi=100)
    if len(scene.points_xy):
        ax.scatter(scene.points_xy[:, 0], scene.points_xy[:, 1], s=0.3, c="0.6", linewidths=0)
    placed = [c for c in scene.cameras if c.x is not None]
    if placed:
        tri = frustum_vertices(np.array([c.x for c in placed]), np.array([c.y for c in placed]),
                               np.array([c.yaw_deg for c in placed]),
                               np.array([c.fov_deg for c in placed]),
                               np.array([c.range for c in placed]))
        for camera, triangle in zip(placed, tri, strict=True):
            colour = "tab:red" if camera.image_id in highlight else "tab:blue"
            ax.fill(triangle[:, 0], triangle[:, 1], alpha=0.08, color=colour)
            ax.plot(camera.x, camera.y, "o", ms=3, color=colour)
            ax.annotate(str(camera.seq), (camera.x, camera.y), fontsize=6)
    ax.set_aspect("equal")
    ax.set_title(f"{len(placed)} of {len(scene.cameras)} cameras in the largest model")
    fig.savefig(out_file, bbox_inches="tight")
    plt.close(fig)
