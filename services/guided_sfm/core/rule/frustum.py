"""Frustum triangles on the ground plane (2D frame units), vectorised over cameras.

The values come checked: a user's by core.edits, the scene's from the model.
"""

from __future__ import annotations

import numpy as np
import shapely


def frustum_vertices(x, y, yaw_deg, fov_deg, range_) -> np.ndarray:
    """(N, 3, 2) triangles in frame units: apex (x, y), axis at yaw (deg CCW), fov, height range."""
    x, y, yaw, fov, rng = (np.atleast_1d(a) for a in np.broadcast_arrays(
        *(np.asarray(v, dtype=float) for v in (x, y, yaw_deg, fov_deg, range_))))
    half = np.radians(fov) / 2.0
    side = rng / np.cos(half)  # apex-to-corner length, so the height along the axis is `range`
    apex = np.stack([x, y], axis=1)
    left, right = np.radians(yaw) + half, np.radians(yaw) - half
    corner_r = apex + side[:, None] * np.stack([np.cos(right), np.sin(right)], axis=1)
    corner_l = apex + side[:, None] * np.stack([np.cos(left), np.sin(left)], axis=1)
    return np.stack([apex, corner_r, corner_l], axis=1)


def frustum_polygons(x, y, yaw_deg, fov_deg, range_) -> np.ndarray:
    """Array of shapely Polygons, one frustum triangle per camera (see frustum_vertices)."""
    return shapely.polygons(frustum_vertices(x, y, yaw_deg, fov_deg, range_))
