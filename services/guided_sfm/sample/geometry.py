"""Poses and quad builders for the sample scenes (world z up; camera x right, y down)."""

from __future__ import annotations

import numpy as np

from guided_sfm.sample.raycast import Quad

UP = np.array([0.0, 0.0, 1.0])


def look(center, yaw_deg: float, pitch_deg: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """cam_from_world (R, t) of a level camera at `center` facing yaw (ccw from +x), pitched."""
    yaw, pitch = np.radians(yaw_deg), np.radians(pitch_deg)
    forward = np.array([np.cos(pitch) * np.cos(yaw), np.cos(pitch) * np.sin(yaw), np.sin(pitch)])
    right = np.cross(forward, UP)
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    r = np.stack([right, down, forward])
    return r, -r @ np.asarray(center, dtype=float)


def qvec_from_matrix(r: np.ndarray) -> list[float]:
    """Unit quaternion (w, x, y, z), w >= 0, of a rotation matrix."""
    m = r
    tr = np.trace(m)
    if tr > 0:
        s = 2 * np.sqrt(tr + 1)
        q = [s / 4, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s]
    else:
        i = int(np.argmax(np.diag(m)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2 * np.sqrt(1 + m[i, i] - m[j, j] - m[k, k])
        q = [0.0] * 4
        q[0] = (m[k, j] - m[j, k]) / s
        q[1 + i] = s / 4
        q[1 + j] = (m[j, i] + m[i, j]) / s
        q[1 + k] = (m[k, i] + m[i, k]) / s
    q = np.array(q) / np.linalg.norm(q)
    return [float(v) for v in (q if q[0] >= 0 else -q)]


def wall_quad(
    center, facing_deg: float, width: float, height: float, texture: int, flat: bool = False
) -> Quad:
    """A vertical rectangle whose front faces yaw `facing_deg`, upright as seen from the front."""
    yaw = np.radians(facing_deg)
    normal = np.array([np.cos(yaw), np.sin(yaw), 0.0])
    right = np.cross(-normal, UP)  # a viewer facing the wall looks along -normal
    top_left = np.asarray(center, dtype=float) - right * width / 2 + UP * height / 2
    return Quad(top_left, right * width, -UP * height, texture, flat)


def horizontal_quad(
    x0: float, y0: float, x1: float, y1: float, z: float, texture: int, flat: bool = False
) -> Quad:
    """An axis-aligned floor, ceiling or table-top rectangle at height z."""
    return Quad(
        np.array([x0, y0, z]),
        np.array([x1 - x0, 0.0, 0.0]),
        np.array([0.0, y1 - y0, 0.0]),
        texture,
        flat,
    )


def box_quads(center_xy, size, facing_deg: float, top: int, sides: int, flat: bool = True) -> list[Quad]:
    """Top and four sides of a box (size = width, depth, height) standing on the floor."""
    w, d, h = size
    yaw = np.radians(facing_deg)
    fwd = np.array([np.cos(yaw), np.sin(yaw), 0.0])
    right = np.cross(-fwd, UP)
    c = np.array([center_xy[0], center_xy[1], h])
    corner = c - right * w / 2 + fwd * d / 2  # front-left of the top, seen from the front
    quads = [Quad(corner - fwd * d, right * w, fwd * d, top, flat)]
    for i, facing in enumerate((0.0, 90.0, 180.0, 270.0)):
        width = w if i % 2 == 0 else d
        dist = d / 2 if i % 2 == 0 else w / 2
        yaw_i = facing_deg + facing
        normal = np.array([np.cos(np.radians(yaw_i)), np.sin(np.radians(yaw_i)), 0.0])
        mid = np.array([center_xy[0], center_xy[1], h / 2]) + normal * dist
        quads.append(wall_quad(mid, yaw_i, width, h, sides, flat))
    return quads
