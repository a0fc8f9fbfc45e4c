"""Robust ground-plane fit and the 2D frame on it, in model coordinates."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from guided_sfm.core.errors import InvalidInput
from guided_sfm.core.types import GroundFrame

MIN_POINTS = 50  # fewer points than this: use the cameras' plane instead
MAX_TILT_DEG = 30.0  # a candidate ground normal must be this close to the cameras' up
MIN_INLIER_SHARE = 0.05  # a thin horizontal slice of a facade is not a ground
RANSAC_ITERATIONS = 300
MAX_SCORED_POINTS = 5000
RELATIVE_THRESHOLD = 0.01  # inlier distance as a share of the points' robust extent


@dataclass(frozen=True)
class Plane:
    """A plane through `point` with unit `normal` (model coordinates)."""

    point: np.ndarray
    normal: np.ndarray

    def distances(self, points: np.ndarray) -> np.ndarray:
        """Signed distances of (N, 3) points to the plane, along the normal."""
        return (points - self.point) @ self.normal


def mean_up(ups: np.ndarray) -> np.ndarray:
    """Unit mean of (M, 3) camera up vectors (world)."""
    total = np.asarray(ups, dtype=float).reshape(-1, 3).sum(axis=0)
    norm = np.linalg.norm(total)
    if norm < 1e-9:
        raise InvalidInput("the cameras' up vectors cancel out; no up direction")
    return total / norm


def _unit(vectors: np.ndarray) -> np.ndarray:
    norms = np.linalg.norm(vectors, axis=-1, keepdims=True)
    return vectors / np.where(norms > 0, norms, 1.0)


def _least_squares(points: np.ndarray) -> Plane:
    centroid = points.mean(axis=0)
    _, _, vt = np.linalg.svd(points - centroid, full_matrices=False)
    return Plane(centroid, vt[-1])


def _threshold(points: np.ndarray) -> float:
    low, high = np.percentile(points, [5, 95], axis=0)
    return max(RELATIVE_THRESHOLD * float(np.linalg.norm(high - low)), 1e-9)


def _candidate_normals(points: np.ndarray, rng: np.random.Generator, up: np.ndarray):
    """Normals and base points of random triples whose normal is within MAX_TILT_DEG of up."""
    triples = np.stack([rng.choice(len(points), 3, replace=False)
                        for _ in range(RANSAC_ITERATIONS)])
    a, b, c = (points[triples[:, i]] for i in range(3))
    cross = np.cross(b - a, c - a)
    keep = np.linalg.norm(cross, axis=1) > 1e-12
    normals = _unit(cross[keep])
    upright = np.abs(normals @ up) >= np.cos(np.radians(MAX_TILT_DEG))
    return normals[upright], a[keep][upright]


def fit_plane(points: np.ndarray, up: np.ndarray, seed: int = 0,
              threshold: float | None = None) -> Plane | None:
    """RANSAC + least-squares plane of (N, 3) points whose normal is near `up`; None if none."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    if len(points) < MIN_POINTS:
        return None
    rng = np.random.default_rng(seed)
    scored = points
    if len(points) > MAX_SCORED_POINTS:
        scored = points[np.sort(rng.choice(len(points), MAX_SCORED_POINTS, replace=False))]
    threshold = _threshold(points) if threshold is None else threshold
    normals, bases = _candidate_normals(scored, rng, up)
    if len(normals) == 0:
        return None
    offsets = np.einsum("kj,kj->k", normals, bases)
    counts = (np.abs(scored @ normals.T - offsets) < threshold).sum(axis=0)
    best = int(np.argmax(counts))
    if counts[best] < max(3, MIN_INLIER_SHARE * len(scored)):
        return None
    return _refit(points, Plane(bases[best], normals[best]), up, threshold)


def _refit(points: np.ndarray, plane: Plane, up: np.ndarray, threshold: float) -> Plane:
    """Least-squares refits on the inliers, the band narrowing to the inliers' own noise."""
    for _ in range(4):
        distances = np.abs(plane.distances(points))
        inliers = distances < threshold
        if inliers.sum() < 3:
            break
        refit = _least_squares(points[inliers])
        if abs(refit.normal @ up) < np.cos(np.radians(MAX_TILT_DEG)):
            break
        plane = refit
        # The generous RANSAC band also catches the foot of walls; 3 sigma (MAD) of the fit won't.
        sigma = 1.4826 * np.median(np.abs(plane.distances(points[inliers])))
        threshold = min(threshold, max(3.0 * sigma, 1e-9))
    return Plane(plane.point, plane.normal if plane.normal @ up >= 0 else -plane.normal)


def _x_axis(centers: np.ndarray, up: np.ndarray) -> np.ndarray:
    """Principal direction of the centres on the plane, pointing from the first to the last."""
    flat = centers - np.outer(centers @ up, up)
    spread = flat - flat.mean(axis=0)
    if len(centers) >= 2 and np.linalg.norm(spread) > 1e-9:
        x_axis = np.linalg.svd(spread, full_matrices=False)[2][0]
        x_axis = _unit(x_axis - (x_axis @ up) * up)
        return x_axis if (flat[-1] - flat[0]) @ x_axis >= 0 else -x_axis
    # One camera (or all at one spot): any horizontal axis will do.
    helper = np.eye(3)[int(np.argmin(np.abs(up)))]
    return _unit(np.cross(up, np.cross(helper, up)))


def ground_frame(points: np.ndarray, centers: np.ndarray, ups: np.ndarray,
                 seed: int = 0) -> GroundFrame:
    """Ground frame from 3D points and camera centres/ups in capture order (model coordinates)."""
    centers = np.asarray(centers, dtype=float).reshape(-1, 3)
    if len(centers) == 0:
        raise InvalidInput("a ground frame needs at least one camera")
    up = mean_up(ups)
    plane = fit_plane(points, up, seed)
    if plane is None:
        plane = Plane(centers.mean(axis=0), up)
    normal = plane.normal
    centroid = centers.mean(axis=0)
    origin = centroid - plane.distances(centroid[None])[0] * normal
    x_axis = _x_axis(centers, normal)
    y_axis = np.cross(normal, x_axis)
    return GroundFrame(origin=origin, x_axis=x_axis, y_axis=y_axis, up=normal)
