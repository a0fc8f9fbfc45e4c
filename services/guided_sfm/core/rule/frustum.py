"""The frustum test (the paper's Algorithm 1, design.md): a pair is removed when the ground
triangles of its two cameras, each at its placed pose, do not meet. Triangles in 2D frame units,
vectorised over cameras; the values come checked (a user's by core.edits, the others from the scene).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import shapely

from guided_sfm.core.errors import InvalidFrustum
from guided_sfm.core.types import CameraEdit, TopDownScene

PlacedFrustum = tuple[float, float, float, float | None, float]  # x, y, yaw_deg, fov_deg, range


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


def placed_frusta(scene: TopDownScene, placements: Mapping[int, CameraEdit],
                  range_scale: float = 1.0) -> dict[int, PlacedFrustum]:
    """The 2D frustum (frame units, deg) of every camera with a placed pose: its placement if it
    has one, else its model pose (cameras outside the largest model have none until placed).

    range_scale multiplies the scene's default ranges, never a range the placement gives.
    """
    frusta: dict[int, PlacedFrustum] = {}
    for camera in scene.cameras:
        placement = placements.get(camera.image_id)
        default_range = None if camera.range is None else camera.range * range_scale
        if placement is not None:
            fov = camera.fov_deg if placement.fov_deg is None else placement.fov_deg
            range_ = default_range if placement.range is None else placement.range
            frusta[camera.image_id] = (placement.x, placement.y, placement.yaw_deg, fov, range_)
        elif camera.registered and camera.x is not None:
            frusta[camera.image_id] = (camera.x, camera.y, camera.yaw_deg, camera.fov_deg,
                                       default_range)
    return frusta


def _triangles(ids: np.ndarray, frusta: Mapping[int, PlacedFrustum]) -> np.ndarray:
    """One frustum polygon per id, built once."""
    values = np.array([frusta[int(i)] for i in ids], dtype=object).reshape(-1, 5)
    missing_fov = [int(i) for i, fov in zip(ids, values[:, 3], strict=True) if fov is None]
    if missing_fov:  # the scene's value, not the user's: an image without intrinsics
        raise InvalidFrustum(f"camera {missing_fov[0]} has no field of view; give fov_deg")
    return frustum_polygons(*(values[:, k].astype(float) for k in range(5)))


def frustum_test(tested: np.ndarray, frusta: Mapping[int, PlacedFrustum]) -> np.ndarray:
    """Mask over (P, 2) pairs whose frustum triangles do not intersect (removed)."""
    if len(tested) == 0:
        return np.zeros(0, dtype=bool)
    ids, index = np.unique(tested, return_inverse=True)
    triangles = _triangles(ids, frusta)
    shapely.prepare(triangles)  # each triangle meets many partners; GEOS reuses its index
    a, b = index.reshape(-1, 2).T
    bounds = shapely.bounds(triangles)
    # Disjoint boxes cannot intersect; numpy rejects them cheaper than a GEOS call each.
    near = np.all((bounds[a, :2] <= bounds[b, 2:]) & (bounds[b, :2] <= bounds[a, 2:]), axis=1)
    apart = ~near
    apart[near] = ~shapely.intersects(triangles[a[near]], triangles[b[near]])
    return apart
