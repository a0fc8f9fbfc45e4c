"""The pruning rules' knobs (an edit set's `tolerances`): names, defaults and validation.

Angles are degrees; counts are numbers of inlier matches; `range_scale` multiplies the default
frustum range (a camera's median point depth) where the edit gives no range of its own.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, fields

from guided_sfm.core.errors import InvalidInput


@dataclass(frozen=True)
class Tolerances:
    """The default rule's tolerances; see docs/pruning-rule.md for how each was chosen."""

    # Median angle between a pair's carried 3D points, seen from the partner's placed pose, and the
    # partner's matched keypoints; true pairs land within ~10 deg, false ones tens of degrees off.
    placement_deg: float = 25.0
    # Fewest carried points for a match-placement verdict; with fewer the frustum test decides.
    placement_min_points: float = 8.0
    # The relative-rotation test frees a placement's yaw by this much with one member moved...
    rotation_deg: float = 20.0
    # ...and by this much more per further moved member (each placement brings its own yaw error;
    # the match-placement test's angle grows by the same).
    yaw_uncertainty_deg: float = 10.0
    # Epipolar residual (deg) the best pose in that range may leave before the pair is removed (the
    # RMS, or where that is above it the median match's under a reweighted fit), and at least
    # this multiple of the RMS the pair's best unconstrained fit leaves.
    epipolar_deg: float = 2.0
    epipolar_ratio: float = 5.0
    # How far a moved camera may sit from where the user put it, as a share of its range; it
    # bounds the pair's translation direction in the relative-rotation test.
    position_share: float = 0.25
    # Where the placements re-orient a pair (its relative rotation, yaw free as above, is no longer
    # the model's), the pair's own two-view rotation may differ from the nearest placed one this much.
    two_view_deg: float = 15.0
    # Fewest inliers for a rotation verdict. COLMAP verifies a pair with 15; the epipolar stage's
    # median residual keeps a weak true pair's few stray matches from removing it, so every verified
    # pair can be judged (30 left twins' weak look-alike pairs untested, a fold alive).
    rotation_min_inliers: float = 15.0
    range_scale: float = 1.0

    def to_dict(self) -> dict[str, float]:
        return {f.name: getattr(self, f.name) for f in fields(self)}


NAMES = tuple(f.name for f in fields(Tolerances))


def resolve(overrides: Mapping[str, object] | None) -> Tolerances:
    """Defaults merged with a user's overrides; raises InvalidInput naming a bad name or value."""
    overrides = dict(overrides or {})
    unknown = sorted(set(overrides) - set(NAMES))
    if unknown:
        raise InvalidInput(f"unknown tolerance {unknown[0]!r}; expected some of {list(NAMES)}")
    for name, value in overrides.items():
        number = value if isinstance(value, int | float) and not isinstance(value, bool) else None
        if number is None or not math.isfinite(number) or number <= 0:
            raise InvalidInput(f"tolerance {name} must be a finite number > 0, got {value!r}")
        if name.endswith("_deg") and number >= 180:
            raise InvalidInput(f"tolerance {name} must be an angle below 180 degrees, got {value!r}")
    return Tolerances(**{k: float(v) for k, v in overrides.items()})
