"""The core's shared maths, in COLMAP's convention: x_cam = R_cam_from_world @ x_world + t.

Rotations and camera centres (batched over leading axes where the pruning rules need it), yaw in
the ground frame, and the rules' two small formulas: the median per segment and the yaw slack.
Camera axes: x right, y down, z forward. Quaternions here are (w, x, y, z); pycolmap's
`Rotation3d.quat` is (x, y, z, w), use `qvec_from_pycolmap` to convert.
"""

from __future__ import annotations

import numpy as np

from guided_sfm.core.types import GroundFrame


def rotation_from_qvec(qvec) -> np.ndarray:
    """3x3 rotation matrix of a quaternion (w, x, y, z); the quaternion need not be unit length."""
    w, x, y, z = np.asarray(qvec, dtype=float) / np.linalg.norm(qvec)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def qvec_from_rotation(rotation: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z) with w >= 0 of a 3x3 rotation matrix."""
    m = np.asarray(rotation, dtype=float)
    # The eigenvector of this symmetric matrix for its largest eigenvalue is the quaternion
    # (Bar-Itzhack); stable for every rotation, unlike the trace formula near 180 deg.
    k = np.array([
        [m[0, 0] - m[1, 1] - m[2, 2], m[1, 0] + m[0, 1], m[2, 0] + m[0, 2], m[2, 1] - m[1, 2]],
        [m[1, 0] + m[0, 1], m[1, 1] - m[0, 0] - m[2, 2], m[2, 1] + m[1, 2], m[0, 2] - m[2, 0]],
        [m[2, 0] + m[0, 2], m[2, 1] + m[1, 2], m[2, 2] - m[0, 0] - m[1, 1], m[1, 0] - m[0, 1]],
        [m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1], m[0, 0] + m[1, 1] + m[2, 2]],
    ]) / 3.0
    _, vectors = np.linalg.eigh(k)
    x, y, z, w = vectors[:, -1]
    q = np.array([w, x, y, z])
    return q if q[0] >= 0 else -q


def qvec_from_pycolmap(xyzw) -> np.ndarray:
    """Reorder pycolmap's (x, y, z, w) quaternion to (w, x, y, z), w >= 0."""
    x, y, z, w = np.asarray(xyzw, dtype=float)
    q = np.array([w, x, y, z]) / np.linalg.norm([w, x, y, z])
    return q if q[0] >= 0 else -q


def camera_centers(cam_from_world_rotation: np.ndarray, cam_from_world_translation) -> np.ndarray:
    """Camera centre(s) in world coordinates, -R^T t: (3, 3) and (3,) give (3,), (N, 3, 3) and
    (N, 3) give (N, 3)."""
    return -np.einsum("...ji,...j->...i", np.asarray(cam_from_world_rotation, dtype=float),
                      np.asarray(cam_from_world_translation, dtype=float))


def rotations_about(axis: np.ndarray, angles_rad: np.ndarray) -> np.ndarray:
    """(N, 3, 3) rotations by each angle (right-handed) about one unit axis (Rodrigues)."""
    n = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    cross = np.array([[0, -n[2], n[1]], [n[2], 0, -n[0]], [-n[1], n[0], 0]])
    cos, sin = np.cos(angles_rad)[:, None, None], np.sin(angles_rad)[:, None, None]
    return cos * np.eye(3) + sin * cross + (1 - cos) * np.outer(n, n)


def viewing_direction(cam_from_world_rotation: np.ndarray) -> np.ndarray:
    """The camera's +z (optical axis) as a world direction: row 2 of cam_from_world."""
    return np.asarray(cam_from_world_rotation, dtype=float)[..., 2, :]


def camera_up(cam_from_world_rotation: np.ndarray) -> np.ndarray:
    """The camera's up (-y, since image y points down) as a world direction."""
    return -np.asarray(cam_from_world_rotation, dtype=float)[..., 1, :]


def wrap_deg(angle_deg):
    """Wrap angles in degrees to (-180, 180]."""
    angle = np.asarray(angle_deg, dtype=float)
    wrapped = angle - 360.0 * np.ceil((angle - 180.0) / 360.0)
    return float(wrapped) if wrapped.ndim == 0 else wrapped


def yaw_in_frame(direction: np.ndarray, frame: GroundFrame):
    """Yaw of world direction(s) in the frame, deg CCW from +x seen from above, in (-180, 180]."""
    d = np.asarray(direction, dtype=float)
    return wrap_deg(np.degrees(np.arctan2(d @ frame.y_axis, d @ frame.x_axis)))


def rotation_angles_deg(rotation_a: np.ndarray, rotation_b: np.ndarray) -> np.ndarray:
    """Angle (deg) of the rotation taking a to b (of a^T b), over the leading axes (broadcast)."""
    trace = np.einsum("...ij,...ij->...", rotation_a, rotation_b)  # trace(a^T b)
    return np.degrees(np.arccos(np.clip((trace - 1) / 2, -1.0, 1.0)))


def horizontal_fov_deg(focal_px: float, width_px: float) -> float:
    """Horizontal field of view in degrees of a pinhole camera: 2 atan(width / (2 f))."""
    return float(np.degrees(2.0 * np.arctan(width_px / (2.0 * focal_px))))


def segment_median(values: np.ndarray, segments: np.ndarray, count: int) -> np.ndarray:
    """Median of values in [0, 360) per segment id in [0, count); NaN for empty segments."""
    return segment_quantile(values, segments, count, 0.5)


def segment_quantile(values: np.ndarray, segments: np.ndarray, count: int,
                     share: float) -> np.ndarray:
    """Quantile (numpy's linear one) of values in [0, 360) per segment id in [0, count); NaN for
    empty segments."""
    # One sort of segment * 512 + value orders by segment, then value: cheaper than a lexsort.
    sizes = np.bincount(segments, minlength=count)
    ordered = np.sort(segments * 512.0 + values) - np.repeat(np.arange(count), sizes) * 512.0
    starts = np.cumsum(sizes) - sizes
    position = share * np.maximum(sizes - 1, 0)
    low = starts + np.floor(position).astype(np.int64)
    high = np.minimum(starts + np.ceil(position).astype(np.int64), max(len(ordered) - 1, 0))
    quantiles = np.full(count, np.nan)
    filled = sizes > 0
    weight = (position - np.floor(position))[filled]
    quantiles[filled] = ordered[low[filled]] * (1 - weight) + ordered[high[filled]] * weight
    return quantiles


def yaw_slack_deg(base_deg: float, per_member_deg: float, moved_members: np.ndarray) -> np.ndarray:
    """The yaw error (deg) a pair's test allows: base with one moved member, plus per_member for
    each further one (each placement brings its own yaw error)."""
    return base_deg + per_member_deg * np.maximum(moved_members - 1, 0)


# The view frames the cameras and the points within a margin around them: the cameras' typical
# range (what they look at), kept between these shares of the cameras' extent, so the cameras
# fill at least about half the view; farther points (stray matches, a distant facade) stay
# reachable by zooming out. The editor's Fit (frontend/js/geometry.js: viewExtent) is the twin.
VIEW_MARGIN_SHARES = (0.2, 0.5)
VIEW_POINT_QUANTILES = (0.02, 0.98)


def view_extent(cameras_xy: np.ndarray, points_xy: np.ndarray,
                min_size: float = 0.0) -> tuple[float, float, float, float] | None:
    """(x0, y0, x1, y1) to frame in a top-down view: the cameras' box (at least min_size wide,
    min_size being the cameras' typical range) and the central points near it; the points'
    central box when there are no cameras."""
    cameras_xy = np.asarray(cameras_xy, dtype=float).reshape(-1, 2)
    points_xy = np.asarray(points_xy, dtype=float).reshape(-1, 2)
    if not len(cameras_xy):
        if not len(points_xy):
            return None
        lo, hi = np.quantile(points_xy, VIEW_POINT_QUANTILES, axis=0)
        return float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])
    lo, hi = cameras_xy.min(axis=0), cameras_xy.max(axis=0)
    centre, half = (lo + hi) / 2, max(min_size, 1e-9) / 2
    lo, hi = np.minimum(lo, centre - half), np.maximum(hi, centre + half)  # one camera: min_size
    size = float((hi - lo).max())
    margin = min(max(min_size, VIEW_MARGIN_SHARES[0] * size), VIEW_MARGIN_SHARES[1] * size)
    near = points_xy[np.all((points_xy >= lo - margin) & (points_xy <= hi + margin), axis=1)]
    if len(near):
        q_lo, q_hi = np.quantile(near, VIEW_POINT_QUANTILES, axis=0)
        lo, hi = np.minimum(lo, q_lo), np.maximum(hi, q_hi)
    return float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])
