"""Rigid motions of the ground plane: a pose is (x, y, yaw in radians) in the scene's 2D frame."""

from __future__ import annotations

import numpy as np


def pose(x: float, y: float, yaw_deg: float) -> np.ndarray:
    return np.array([x, y, np.radians(yaw_deg)], dtype=float)


def _rot(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s], [s, c]])


def compose(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a then b expressed in a's frame (a ⊕ b)."""
    return np.array([*(a[:2] + _rot(a[2]) @ b[:2]), a[2] + b[2]])


def inverse(a: np.ndarray) -> np.ndarray:
    return np.array([*(-_rot(-a[2]) @ a[:2]), -a[2]])


def between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The motion taking pose a to pose b, in a's frame (a⁻¹ ⊕ b)."""
    return compose(inverse(a), b)


def continue_forward(previous: np.ndarray, last: np.ndarray) -> np.ndarray:
    """The pose one step after last at the same motion (step and turn) as previous -> last."""
    return compose(last, between(previous, last))


def fit_rigid(source: np.ndarray, target: np.ndarray, reach: float) -> np.ndarray:
    """The motion (as a pose applied on the left) taking source poses (N, 3) closest to target
    poses: 2D Procrustes on positions plus a point `reach` ahead of each camera, so yaws count."""
    def with_heads(poses: np.ndarray, reach: float) -> np.ndarray:
        heads = poses[:, :2] + reach * np.stack([np.cos(poses[:, 2]), np.sin(poses[:, 2])], 1)
        return np.vstack([poses[:, :2], heads])

    src, dst = with_heads(source, reach), with_heads(target, reach)
    src_mean, dst_mean = src.mean(0), dst.mean(0)
    cov = (dst - dst_mean).T @ (src - src_mean)
    angle = np.arctan2(cov[1, 0] - cov[0, 1], cov[0, 0] + cov[1, 1])
    shift = dst_mean - _rot(angle) @ src_mean
    return np.array([shift[0], shift[1], angle])


def apply(motion: np.ndarray, poses: np.ndarray) -> np.ndarray:
    """Each pose (N, 3) moved by motion (a pose applied on the left)."""
    return np.array([compose(motion, p) for p in np.asarray(poses).reshape(-1, 3)])
