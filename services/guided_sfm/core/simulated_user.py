"""A simulated user for the headless loop: places cameras near their true poses, with noise."""

from __future__ import annotations

import numpy as np

from guided_sfm.core.geometry import viewing_direction, yaw_in_frame
from guided_sfm.core.metrics import Similarity
from guided_sfm.core.truth import Truth
from guided_sfm.core.types import CameraEdit, TopDownScene

OFFSET_M = 0.3  # how far from the truth the simulated user drops a camera (metres)
YAW_NOISE_DEG = 10.0  # and how far off its heading


def place_cameras(scene: TopDownScene, truth: Truth, names: list[str],
                  truth_from_model: Similarity, seed: int = 0,
                  offset_m: float = OFFSET_M, yaw_noise_deg: float = YAW_NOISE_DEG
                  ) -> list[CameraEdit]:
    """Edits that put each named camera at its true 2D pose plus a fixed-size random error."""
    rng = np.random.default_rng(seed)
    by_name = {c.name: c for c in scene.cameras}
    rotation = np.asarray(truth_from_model.rotation)
    edits = []
    for name in sorted(names):
        true = truth.cameras[name]
        center = rotation.T @ (true.center - truth_from_model.translation) / truth_from_model.scale
        direction = rotation.T @ viewing_direction(true.rotation)
        xy = scene.frame.to_2d(center[None])[0]
        angle = rng.uniform(0, 2 * np.pi)
        xy = xy + offset_m / truth_from_model.scale * np.array([np.cos(angle), np.sin(angle)])
        yaw = float(yaw_in_frame(direction, scene.frame)) + rng.choice([-1, 1]) * yaw_noise_deg
        edits.append(CameraEdit(by_name[name].image_id, float(xy[0]), float(xy[1]), yaw))
    return edits
