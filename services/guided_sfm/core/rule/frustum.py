"""Frustum triangles on the ground plane (2D frame units), vectorised over cameras."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import shapely

from guided_sfm.core.errors import InvalidFrustum


def _label(ids: Sequence | None, index: int) -> str:
    return f"camera {ids[index]}" if ids is not None else f"frustum #{index}"


def _first_bad(mask: np.ndarray) -> int | None:
    bad = np.flatnonzero(~mask)
    return int(bad[0]) if len(bad) else None


def validate_frusta(x, y, yaw_deg, fov_deg, range_, ids: Sequence | None = None) -> None:
    """Raise InvalidFrustum unless every pose is finite, fov in (0, 180) deg and range > 0."""
    x, y, yaw, fov, rng = _arrays(x, y, yaw_deg, fov_deg, range_)
    checks = [
        ("x", x, np.isfinite(x), "must be a finite number"),
        ("y", y, np.isfinite(y), "must be a finite number"),
        ("yaw_deg", yaw, np.isfinite(yaw), "must be a finite number"),
        ("fov_deg", fov, np.isfinite(fov) & (fov > 0) & (fov < 180),
         "must be a finite angle in the open interval (0, 180) degrees"),
        ("range", rng, np.isfinite(rng) & (rng > 0), "must be a finite number > 0"),
    ]
    for name, values, ok, rule in checks:
        index = _first_bad(ok)
        if index is not None:
            raise InvalidFrustum(f"{_label(ids, index)}: {name} {rule}, got {values[index]}")


def _arrays(*values) -> list[np.ndarray]:
    try:
        arrays = [np.asarray(v, dtype=float) for v in values]
    except (TypeError, ValueError) as exc:
        raise InvalidFrustum(f"frustum values must be numbers: {exc}") from exc
    return [np.atleast_1d(a) for a in np.broadcast_arrays(*arrays)]


def frustum_vertices(x, y, yaw_deg, fov_deg, range_, ids: Sequence | None = None) -> np.ndarray:
    """(N, 3, 2) triangles in frame units: apex (x, y), axis at yaw (deg CCW), fov, height range."""
    validate_frusta(x, y, yaw_deg, fov_deg, range_, ids)
    x, y, yaw, fov, rng = _arrays(x, y, yaw_deg, fov_deg, range_)
    half = np.radians(fov) / 2.0
    side = rng / np.cos(half)  # apex-to-corner length, so the height along the axis is `range`
    apex = np.stack([x, y], axis=1)
    left, right = np.radians(yaw) + half, np.radians(yaw) - half
    corner_r = apex + side[:, None] * np.stack([np.cos(right), np.sin(right)], axis=1)
    corner_l = apex + side[:, None] * np.stack([np.cos(left), np.sin(left)], axis=1)
    return np.stack([apex, corner_r, corner_l], axis=1)


def frustum_polygons(x, y, yaw_deg, fov_deg, range_, ids: Sequence | None = None) -> np.ndarray:
    """Array of shapely Polygons, one frustum triangle per camera (see frustum_vertices)."""
    return shapely.polygons(frustum_vertices(x, y, yaw_deg, fov_deg, range_, ids))
