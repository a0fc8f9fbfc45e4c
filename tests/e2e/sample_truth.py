"""The sample's ground truth against a REST scene: which cameras are wrong, where they belong in the
scene's 2D frame, and the key presses that carry a selection there."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from guided_sfm.core import metrics, simulated_user
from guided_sfm.core.geometry import rotation_from_qvec, wrap_deg
from guided_sfm.core.truth import Truth, TruthCamera, load_truth
from guided_sfm.core.types import TopDownScene
from guided_sfm.sample import DEFAULT_LAYOUT
from guided_sfm.sample.writer import build_layout


def find_truth(data_dir: Path) -> Truth:
    """The truth of the sample `serve --sample` made: its truth.json if one is kept under the data
    dir, else the poses of the default layout (seed 0) that the sample renders, named alike."""
    found = sorted(Path(data_dir).rglob("truth.json"))
    if found:
        return load_truth(found[0])
    layout = build_layout(DEFAULT_LAYOUT, 0)
    cameras = {f"{i:04d}.jpg": TruthCamera(r, np.asarray(t, float), -r.T @ np.asarray(t, float))
               for i, (r, t) in enumerate(layout.poses)}
    return Truth(up=np.array([0.0, 0.0, 1.0]), cameras=cameras, intrinsics=None, depth_dir=None)


def _poses(scene: dict) -> dict[str, metrics.CameraPose]:
    return {c["name"]: (rotation_from_qvec(c["qvec"]), np.asarray(c["center"], float))
            for c in scene["cameras"] if c["registered"] and c["center"] is not None}


def alignment(scene: dict, truth: Truth, reference: list[str] | None = None) -> metrics.Similarity:
    """Similarity from the scene's model to the truth (LO-RANSAC on the reference cameras)."""
    poses = _poses(scene)
    names = sorted(n for n in (reference or poses) if n in poses and n in truth.cameras)
    return metrics.align_similarity(np.array([poses[n][1] for n in names]),
                                    np.array([truth.cameras[n].center for n in names]))


def camera_errors(scene: dict, truth: Truth, sim: metrics.Similarity) -> dict[str, metrics.CameraError]:
    true_poses = {n: (c.rotation, c.center) for n, c in truth.cameras.items()}
    return metrics.camera_errors(_poses(scene), true_poses, sim)


def wrong_cameras(scene: dict, truth: Truth) -> tuple[list[str], metrics.Similarity]:
    sim = alignment(scene, truth)
    bad = metrics.classify(camera_errors(scene, truth, sim))
    return sorted(n for n, wrong in bad.items() if wrong), sim


def runs(scene: dict, names: list[str]) -> list[list[dict]]:
    """Runs of consecutive (capture order) registered cameras among `names`."""
    wanted = set(names)
    found: list[list[dict]] = [[]]
    for camera in sorted(scene["cameras"], key=lambda c: c["seq"]):
        if camera["name"] in wanted and camera["registered"]:
            found[-1].append(camera)
        elif found[-1]:
            found.append([])
    return [run for run in found if run]


def rigid_segments(run: list[dict], targets: dict[int, tuple[float, float, float]],
                   tolerance: float) -> list[list[dict]]:
    """Split a run into the fewest consecutive pieces that one rigid move each puts in place
    (every camera within `tolerance` of its target, scene units); a folded run needs several."""
    pieces, start = [], 0
    while start < len(run):
        end = len(run)
        while end > start + 1 and _rigid_residual(run[start:end], targets) > tolerance:
            end -= 1
        pieces.append(run[start:end])
        start = end
    return pieces


def _rigid_residual(piece: list[dict], targets: dict[int, tuple[float, float, float]]) -> float:
    now = [(c["x"], c["y"], c["yaw_deg"]) for c in piece]
    goal = [targets[c["image_id"]] for c in piece]
    angle, dx, dy = rigid_fit(now, goal)
    moved = move_rigidly(now, angle, dx, dy)
    return max(math.hypot(m[0] - g[0], m[1] - g[1]) for m, g in zip(moved, goal, strict=True))


def move_rigidly(poses: list[tuple[float, float, float]], angle_deg: float, dx: float,
                 dy: float) -> list[tuple[float, float, float]]:
    """What the editor does: turn about the centroid, then translate (frontend/js/geometry.js)."""
    xy = np.array([p[:2] for p in poses])
    centre = xy.mean(axis=0)
    c, s = math.cos(math.radians(angle_deg)), math.sin(math.radians(angle_deg))
    turned = (xy - centre) @ np.array([[c, s], [-s, c]]) + centre + [dx, dy]
    return [(x, y, wrap_deg(p[2] + angle_deg)) for (x, y), p in zip(turned, poses, strict=True)]


def true_placements(scene: dict, truth: Truth, names: list[str],
                    sim: metrics.Similarity) -> dict[int, tuple[float, float, float]]:
    """Image id -> (x, y, yaw_deg) of each camera's true pose in the scene's 2D frame."""
    edits = simulated_user.place_cameras(TopDownScene.from_dict(scene), truth, names, sim,
                                         offset_m=0.0, yaw_noise_deg=0.0)
    return {e.image_id: (e.x, e.y, e.yaw_deg) for e in edits}


def rigid_fit(now: list[tuple[float, float, float]],
              target: list[tuple[float, float, float]]) -> tuple[float, float, float]:
    """Rotation (deg) about the centroid of `now`, then translation, bringing it onto `target`."""
    a = np.array([p[:2] for p in now])
    b = np.array([p[:2] for p in target])
    ca, cb = a.mean(axis=0), b.mean(axis=0)
    turn = [math.radians(wrap_deg(t[2] - n[2])) for n, t in zip(now, target, strict=True)]
    angle = math.degrees(math.atan2(np.mean(np.sin(turn)), np.mean(np.cos(turn))))
    if len(now) > 1 and np.linalg.norm(a - ca) > 1e-9:
        pa, pb = a - ca, b - cb
        cross = float(np.sum(pa[:, 0] * pb[:, 1] - pa[:, 1] * pb[:, 0]))
        dot = float(np.sum(pa * pb))
        angle = math.degrees(math.atan2(cross, dot))
    return angle, float(cb[0] - ca[0]), float(cb[1] - ca[1])


def key_plan(angle_deg: float, dx: float, dy: float, step: float, rotate_deg: float,
             shift: int = 5) -> list[str]:
    """Playwright key presses: q/r turn by rotate_deg (shift: x shift), arrows move by step."""
    keys: list[str] = []

    def presses(count: int, small: str, big: str) -> None:
        keys.extend([big] * (abs(count) // shift) + [small] * (abs(count) % shift))

    turns = round(angle_deg / rotate_deg)
    presses(turns, "q" if turns > 0 else "r", "Shift+Q" if turns > 0 else "Shift+R")
    across = round(dx / step)
    presses(across, "ArrowRight" if across > 0 else "ArrowLeft",
            "Shift+ArrowRight" if across > 0 else "Shift+ArrowLeft")
    up = round(dy / step)
    presses(up, "ArrowUp" if up > 0 else "ArrowDown", "Shift+ArrowUp" if up > 0 else "Shift+ArrowDown")
    return keys


def planned_move(angle_deg: float, dx: float, dy: float, step: float,
                 rotate_deg: float) -> tuple[float, float, float]:
    """The move key_plan's presses make: the angle and offsets rounded to whole steps."""
    return (round(angle_deg / rotate_deg) * rotate_deg, round(dx / step) * step, round(dy / step) * step)
