"""Plain value types shared by the core modules (no behaviour beyond conversions)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

PairKey = tuple[int, int]
"""An image pair as (smaller image id, larger image id)."""

Progress = Callable[[str, float], None]
"""progress(stage, fraction in [0, 1]) reported by long steps."""


DEFAULT_RULE, PAPER_RULE = "default", "paper"
RULES = (DEFAULT_RULE, PAPER_RULE)
"""An edit set's `rule`: the product's default rule, or the paper's triangle test alone."""


def pair_key(a: int, b: int) -> PairKey:
    """The canonical (sorted) key of an image pair."""
    return (a, b) if a < b else (b, a)


def no_progress(stage: str, fraction: float) -> None:
    """A progress callback that ignores reports."""


@dataclass(frozen=True)
class GroundFrame:
    """A 2D frame on the fitted ground plane, in model coordinates (right-handed: up = x cross y)."""

    origin: np.ndarray
    x_axis: np.ndarray
    y_axis: np.ndarray
    up: np.ndarray

    def to_2d(self, points: np.ndarray) -> np.ndarray:
        """Project (N, 3) model points to (N, 2) frame coordinates."""
        rel = np.asarray(points, dtype=float).reshape(-1, 3) - self.origin
        return np.stack([rel @ self.x_axis, rel @ self.y_axis], axis=1)

    def to_dict(self) -> dict[str, list[float]]:
        return {k: [float(v) for v in getattr(self, k)] for k in ("origin", "x_axis", "y_axis", "up")}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> GroundFrame:
        return cls(**{k: np.asarray(data[k], dtype=float) for k in ("origin", "x_axis", "y_axis", "up")})


@dataclass(frozen=True)
class SceneCamera:
    """One image in the top-down scene; pose fields are None when it is not in the largest model."""

    image_id: int
    name: str
    seq: int
    registered: bool
    model: int | None
    x: float | None
    y: float | None
    yaw_deg: float | None
    fov_deg: float | None
    range: float | None
    center: tuple[float, float, float] | None
    qvec: tuple[float, float, float, float] | None  # world-to-camera (w, x, y, z)
    # outside the largest model: {x, y, yaw_deg} in its own model placed beside the largest
    group_pose: dict[str, float] | None = None

    def to_dict(self) -> dict[str, Any]:
        data = dict(self.__dict__)
        for key in ("center", "qvec"):
            data[key] = None if data[key] is None else [float(v) for v in data[key]]
        return data


@dataclass(frozen=True)
class TopDownScene:
    """The contract's scene object: frame, cameras (capture order), subsampled 2D points, models."""

    frame: GroundFrame
    cameras: list[SceneCamera]
    points_xy: np.ndarray
    models: list[dict[str, int]] = field(default_factory=list)

    def camera(self, image_id: int) -> SceneCamera | None:
        return next((c for c in self.cameras if c.image_id == image_id), None)

    def to_dict(self) -> dict[str, Any]:
        return {
            "frame": self.frame.to_dict(),
            "cameras": [c.to_dict() for c in self.cameras],
            "points": {"xy": np.round(self.points_xy, 4).tolist()},
            "models": list(self.models),
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> TopDownScene:
        cameras = [SceneCamera(**c) for c in data["cameras"]]
        xy = np.asarray(data["points"]["xy"], dtype=float).reshape(-1, 2)
        return cls(GroundFrame.from_dict(data["frame"]), cameras, xy, list(data.get("models", [])))


@dataclass(frozen=True)
class CameraEdit:
    """A placement: the user's 2D pose for one camera in the scene's frame (frame units, yaw in
    degrees); fov/range None = keep the scene's."""

    image_id: int
    x: float
    y: float
    yaw_deg: float
    fov_deg: float | None = None
    range: float | None = None


@dataclass(frozen=True)
class EditSet:
    """What a user asks of one correction round. core.edits.parse_edits makes one from a body and
    checks every value; the core trusts it (each camera once, known images, a rule of RULES,
    tolerances by name)."""

    cameras: list[CameraEdit] = field(default_factory=list)
    delete_pairs: list[PairKey] = field(default_factory=list)
    rule: str = DEFAULT_RULE
    tolerances: dict[str, float] = field(default_factory=dict)  # overrides of Tolerances()


@dataclass(frozen=True)
class PruneResult:
    """Pairs a rule deletes, with the reasons for each: the tests that removed it, and "manual"
    for the user's own deletions."""

    deleted: list[PairKey]
    reasons: dict[PairKey, tuple[str, ...]]
    # pairs the match-placement test alone removed, kept because deleting them splits the match graph
    kept_to_connect: list[PairKey]

    @property
    def removed_by_test(self) -> dict[str, int]:
        counts: dict[str, int] = {}
        for tests in self.reasons.values():
            for test in tests:
                counts[test] = counts.get(test, 0) + 1
        return counts
