"""The user's placement as a position prior for the re-map (issue 20).

The placement is a 2D pose on the ground plane of the base model's top-down scene, so the prior is
expressed in the base model's frame: (x, y) on the plane, lifted along the plane's normal by the
camera's own height above the plane in the base model (the user places on the ground, not in
height; a camera without a base pose takes the median height of the registered ones). No heading:
COLMAP's pose prior holds a position (and gravity, which the incremental mapper does not use).

Every registered camera of the base model gets a prior, the unmoved ones at their base centres: the
user saw them there and left them, and COLMAP needs at least three registered priors before its
bundle adjustment aligns the map to them (a similarity, robustly) and then holds each camera to
its prior with the prior's covariance. Its standard deviation, horizontally and in height, is the
rule's allowance for the user's error: position_share x the camera's range, the same distance
within which the relative-rotation test lets a moved camera sit away from where it was put.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from guided_sfm.core.types import CameraEdit, SceneCamera, TopDownScene


@dataclass(frozen=True)
class PositionPrior:
    """A camera centre the re-map is held to: model coordinates of the base, with its covariance."""

    image_id: int
    position: np.ndarray  # (3,)
    covariance: np.ndarray  # (3, 3)


def _height(camera: SceneCamera, scene: TopDownScene) -> float:
    return float((np.asarray(camera.center) - scene.frame.origin) @ scene.frame.up)


def _lifted(scene: TopDownScene, x: float, y: float, height: float) -> np.ndarray:
    frame = scene.frame
    return frame.origin + x * frame.x_axis + y * frame.y_axis + height * frame.up


def isotropic(sigma: float) -> np.ndarray:
    """The covariance of a position known to sigma along every axis."""
    return sigma**2 * np.eye(3)


def placement_priors(scene: TopDownScene, placements: Mapping[int, CameraEdit],
                     position_share: float) -> list[PositionPrior]:
    """A prior per registered camera (at its placement if moved, else its base centre) and per
    placed camera outside the model; sorted by image id."""
    posed = {c.image_id: c for c in scene.cameras if c.center is not None and c.x is not None}
    if not posed:
        return []
    heights = [_height(c, scene) for c in posed.values()]
    ranges = [c.range for c in posed.values() if c.range]
    typical_range = float(np.median(ranges)) if ranges else 1.0
    priors = []
    for image_id in sorted(set(posed) | set(placements)):
        camera, placement = posed.get(image_id), placements.get(image_id)
        # the scene's range (median point depth), not an edit's frustum range: it sizes the
        # placement's uncertainty, as in the rule's tests
        reach = (camera.range if camera else None) or typical_range
        covariance = isotropic(position_share * reach)
        if placement is None:
            position = np.asarray(camera.center, dtype=float)
        else:
            height = _height(camera, scene) if camera else float(np.median(heights))
            position = _lifted(scene, placement.x, placement.y, height)
        priors.append(PositionPrior(image_id, position, covariance))
    return priors
