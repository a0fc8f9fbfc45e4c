"""Evaluation (design.md, paper 7.3): similarity alignment, camera errors, pruning scores."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

import numpy as np

from guided_sfm.core.errors import InvalidInput
from guided_sfm.core.geometry import rotation_angles_deg
from guided_sfm.core.types import PairKey

ALIGN_THRESHOLD_M = 0.15
WRONG_CENTER_M = 0.3
WRONG_ROTATION_DEG = 10.0
LOCAL_STEPS = 10

CameraPose = tuple[np.ndarray, np.ndarray]  # (R cam_from_world 3x3, centre 3) in its own world


@dataclass(frozen=True)
class Similarity:
    """dst = scale * rotation @ src + translation; `inliers` marks the points that agreed."""

    scale: float
    rotation: np.ndarray
    translation: np.ndarray
    inliers: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))

    def apply(self, points: np.ndarray) -> np.ndarray:
        """Map (N, 3) or (3,) points from the source world to the destination world."""
        points = np.asarray(points, dtype=float)
        return self.scale * points @ self.rotation.T + self.translation

    def apply_rotation(self, cam_from_world: np.ndarray) -> np.ndarray:
        """cam_from_world rotation(s) (..., 3, 3) expressed in the destination world."""
        # world_from_cam maps with the rotation, so cam_from_world picks up its inverse.
        return np.asarray(cam_from_world, dtype=float) @ self.rotation.T


def umeyama(src: np.ndarray, dst: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Least-squares similarity (scale, rotation, translation) with dst ~ s R src + t."""
    mean_src, mean_dst = src.mean(axis=0), dst.mean(axis=0)
    a, b = src - mean_src, dst - mean_dst
    u, sigma, vt = np.linalg.svd(b.T @ a / len(src))
    sign = np.eye(3)
    if np.linalg.det(u) * np.linalg.det(vt) < 0:
        sign[2, 2] = -1.0
    rotation = u @ sign @ vt
    variance = (a * a).sum() / len(src)
    scale = float(np.trace(np.diag(sigma) @ sign) / variance) if variance > 0 else 1.0
    return scale, rotation, mean_dst - scale * rotation @ mean_src


def _residuals(model, src: np.ndarray, dst: np.ndarray) -> np.ndarray:
    scale, rotation, translation = model
    return np.linalg.norm(scale * src @ rotation.T + translation - dst, axis=1)


def _local_optimise(model, src, dst, threshold):
    """Refit on the inliers while their count grows (the LO step of LO-RANSAC)."""
    inliers = _residuals(model, src, dst) < threshold
    for _ in range(LOCAL_STEPS):
        if inliers.sum() < 3:
            break
        refit = umeyama(src[inliers], dst[inliers])
        refit_inliers = _residuals(refit, src, dst) < threshold
        if refit_inliers.sum() < inliers.sum():
            break
        model, inliers = refit, refit_inliers
    return model, inliers


def _check_correspondences(src: np.ndarray, dst: np.ndarray) -> None:
    if src.shape != dst.shape or src.ndim != 2 or src.shape[1] != 3:
        raise InvalidInput(f"alignment needs two (N, 3) arrays, got {src.shape} and {dst.shape}")
    if len(src) < 3:
        raise InvalidInput(f"alignment needs at least 3 reference cameras, got {len(src)}")
    if not (np.isfinite(src).all() and np.isfinite(dst).all()):
        raise InvalidInput("alignment points must be finite")


def _sample_is_degenerate(points: np.ndarray) -> bool:
    return np.linalg.norm(np.cross(points[1] - points[0], points[2] - points[0])) < 1e-12


def _confident(inlier_share: float, iterations_done: int, confidence: float = 0.999) -> bool:
    """Whether a better consensus is unlikely after so many minimal samples (RANSAC bound)."""
    miss_all = 1.0 - inlier_share**3
    if miss_all >= 1.0:
        return False
    return miss_all <= 0 or iterations_done >= np.log(1 - confidence) / np.log(miss_all)


def align_similarity(src: np.ndarray, dst: np.ndarray, threshold: float = ALIGN_THRESHOLD_M,
                     iterations: int = 1000, seed: int = 0) -> Similarity:
    """LO-RANSAC Umeyama similarity taking src (N, 3) to dst (N, 3); threshold in dst units."""
    src, dst = np.asarray(src, dtype=float), np.asarray(dst, dtype=float)
    _check_correspondences(src, dst)
    rng = np.random.default_rng(seed)
    best_model, best_inliers = umeyama(src, dst), np.zeros(len(src), dtype=bool)
    for done in range(iterations):
        sample = rng.choice(len(src), 3, replace=False)
        if _sample_is_degenerate(src[sample]):
            continue
        model, inliers = _local_optimise(umeyama(src[sample], dst[sample]), src, dst, threshold)
        if inliers.sum() > best_inliers.sum():
            best_model, best_inliers = model, inliers
        if best_inliers.all() or _confident(best_inliers.mean(), done + 1):
            break
    if best_inliers.sum() >= 3:
        best_model = umeyama(src[best_inliers], dst[best_inliers])
        best_inliers = _residuals(best_model, src, dst) < threshold
    scale, rotation, translation = best_model
    return Similarity(scale, rotation, translation, best_inliers)


@dataclass(frozen=True)
class CameraError:
    """A camera's error after alignment: centre distance (truth units) and rotation (deg)."""

    center: float
    rotation_deg: float


def camera_errors(est: Mapping[str, CameraPose], truth: Mapping[str, CameraPose],
                  sim: Similarity) -> dict[str, CameraError]:
    """Errors of every camera in both est and truth, est mapped into truth by `sim`."""
    errors = {}
    for name in sorted(set(est) & set(truth)):
        rotation_est, center_est = est[name]
        rotation_gt, center_gt = truth[name]
        errors[name] = CameraError(
            center=float(np.linalg.norm(sim.apply(center_est) - np.asarray(center_gt))),
            rotation_deg=float(rotation_angles_deg(np.asarray(rotation_gt, dtype=float),
                                                   sim.apply_rotation(rotation_est))),
        )
    return errors


def classify(errors: Mapping[str, CameraError], center_tol: float = WRONG_CENTER_M,
             rotation_tol_deg: float = WRONG_ROTATION_DEG) -> dict[str, bool]:
    """True for a (registered) camera off by > center_tol or > rotation_tol_deg after alignment."""
    return {name: e.center > center_tol or e.rotation_deg > rotation_tol_deg
            for name, e in errors.items()}


@dataclass(frozen=True)
class EvaluationReport:
    """Camera outcome lists (image names) and errors of one model against ground truth."""

    wrong: list[str]
    fixed: list[str]
    still_wrong: list[str]
    broken: list[str]  # right before the edit, wrong after it
    unregistered: list[str]
    translation_mse: float  # over the registered target cameras, squared truth units
    rotation_mae_deg: float
    num_models: int
    errors: dict[str, CameraError] = field(default_factory=dict)

    def to_dict(self) -> dict:
        """Plain JSON-ready values: counts, lists, and NaN as None."""
        def number(value: float) -> float | None:
            return None if np.isnan(value) else float(value)

        lists = ("wrong", "fixed", "still_wrong", "broken", "unregistered")
        return {
            **{name: list(getattr(self, name)) for name in lists},
            **{f"num_{name}": len(getattr(self, name)) for name in lists},
            "translation_mse": number(self.translation_mse),
            "rotation_mae_deg": number(self.rotation_mae_deg),
            "num_models": self.num_models,
        }


def _mean(values: list[float]) -> float:
    return float(np.mean(values)) if values else float("nan")


def evaluate(est: Mapping[str, CameraPose], truth: Mapping[str, CameraPose], num_models: int,
             reference: Iterable[str] | None = None, targets: Iterable[str] | None = None,
             before: EvaluationReport | None = None, seed: int = 0) -> EvaluationReport:
    """Align est to truth on the reference cameras, then classify and score every camera."""
    common = sorted(set(est) & set(truth))
    names = common if reference is None else sorted(set(reference) & set(common))
    sim = align_similarity(np.array([est[n][1] for n in names]).reshape(-1, 3),
                           np.array([truth[n][1] for n in names]).reshape(-1, 3), seed=seed)
    errors = camera_errors(est, truth, sim)
    wrong = sorted(name for name, bad in classify(errors).items() if bad)
    was_wrong = set(before.wrong) if before is not None else set()
    scored = [n for n in (common if targets is None else sorted(targets)) if n in errors]
    return EvaluationReport(
        wrong=wrong,
        fixed=sorted(was_wrong - set(wrong) - (set(truth) - set(est))),
        still_wrong=sorted(was_wrong & set(wrong)) if before is not None else wrong,
        broken=sorted(set(wrong) - was_wrong) if before is not None else [],
        unregistered=sorted(set(truth) - set(est)),
        translation_mse=_mean([errors[n].center ** 2 for n in scored]),
        rotation_mae_deg=_mean([errors[n].rotation_deg for n in scored]),
        num_models=num_models,
        errors=errors,
    )


def pruning_scores(deleted: set[PairKey], false_pairs: set[PairKey]) -> tuple[float, float, float]:
    """(precision, recall, F1) of deleted pairs against false ones; an empty side scores 1.0."""
    deleted, false_pairs = set(deleted), set(false_pairs)
    return scores_from_counts(len(deleted & false_pairs), len(deleted), len(false_pairs))


def scores_from_counts(hits: int, deleted: int, false_pairs: int) -> tuple[float, float, float]:
    """(precision, recall, F1) from counts: deleted pairs, false pairs, and false ones deleted."""
    # Deleting nothing makes no wrong deletion; with no false pair there is nothing to miss.
    precision = hits / deleted if deleted else 1.0
    recall = hits / false_pairs if false_pairs else 1.0
    if not deleted and not false_pairs:
        return 1.0, 1.0, 1.0
    f1 = 2 * precision * recall / (precision + recall) if hits else 0.0
    return precision, recall, f1
