"""Time the default rule: 300 cameras, each paired with its 30 nearest, real inlier counts, every
camera moved (the worst case: every pair is tested). Prints the time of each test and the total.

Match counts follow the rendered murals sample (median ~150 inliers, a long tail to ~800).
Optionally also time gathering the evidence from a real workspace (models + database, read-only)
and the whole preview there (what `GET .../preview` runs: every pair's id and inlier count for the
components, the scene, the moved cameras' evidence, the rule) with a capture-order run of
--moved cameras shifted 0.3 m and turned 10 deg. At 1,000 cameras: a workspace written by
benchmarks/synthetic_workspace.py (a rendered capture of that size takes an hour to reconstruct).
Run: .venv/bin/python benchmarks/bench_rule.py [--runs N] [--cameras N] [--workspace WS [--moved N]]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from guided_sfm.core.rule import evidence as ev
from guided_sfm.core.rule.driver import prune_pairs, tested_pairs
from guided_sfm.core.rule.frustum import frustum_test, placed_frusta
from guided_sfm.core.rule.match_placement import placement_test
from guided_sfm.core.rule.motion import motions_of
from guided_sfm.core.rule.relative_pose import relative_pose_test
from guided_sfm.core.rule.relative_rotation import rotation_test
from guided_sfm.core.rule.separates import partners_of_moved
from guided_sfm.core.rule.tolerances import Tolerances
from guided_sfm.core.types import CameraEdit, EditSet
from guided_sfm.core.workspace import Workspace

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the tests' hand-made captures
from tests.core.synthetic import Capture, in_view, look  # noqa: E402

SPACING_M = 0.5  # between consecutive cameras along the walk
TURNED_SHARE = 0.1  # cameras the user also turns by 90 deg (forces the per-pair two-view check)


def walk_poses(count: int, rng: np.random.Generator) -> dict:
    """Cameras along a rectangular loop, heading along it, +-30 deg of sway, eye height."""
    side = count * SPACING_M / 4
    poses = {}
    for i in range(count):
        s = i * SPACING_M
        edge, along = int(s // side) % 4, s % side
        corners = [(0, 0), (side, 0), (side, side), (0, side)]
        heading = 90.0 * edge
        x0, y0 = corners[edge]
        center = (x0 + along * np.cos(np.radians(heading)), y0 + along * np.sin(np.radians(heading)), 1.5)
        poses[i + 1] = look(center, heading + rng.uniform(-30, 30), rng.uniform(-10, 0))
    return poses


def synthetic_capture(count: int, neighbours: int, seed: int = 0, moved_share: float = 1.0):
    """(scene, edits, pairs, evidence): each camera paired with its nearest along the walk; every
    camera moved, or every other stretch of the walk where moved_share < 1 (then the pairs between
    unmoved cameras are candidates for the `separates` reason too)."""
    rng = np.random.default_rng(seed)
    capture = Capture(walk_poses(count, rng))
    for i in range(1, count + 1):
        for j in range(i + 1, i + neighbours // 2 + 1):
            j = (j - 1) % count + 1
            wanted = int(np.clip(rng.lognormal(np.log(150), 0.8), 20, 800))
            rotation, translation = capture.poses[i]
            ahead = rng.uniform([-4, -2, 2], [4, 2, 10], size=(3 * wanted, 3))
            seen = (ahead - translation) @ rotation  # world points in front of camera i
            seen = seen[in_view(capture.poses[j], seen, 89.0)][:wanted]
            if len(seen) >= 8:
                capture.match(i, j, seen)
    scene, evidence = capture.scene(), capture.evidence()
    edits = []
    stretch = max(1, round(count * moved_share / 4))  # four moved stretches
    for index, camera in enumerate(scene.cameras):
        if moved_share < 1.0 and index % (count // 4) >= stretch:
            continue
        turn = 90.0 if rng.random() < TURNED_SHARE else rng.choice([-10.0, 10.0])
        angle = rng.uniform(0, 2 * np.pi)
        edits.append(CameraEdit(camera.image_id, camera.x + 0.3 * np.cos(angle),
                                camera.y + 0.3 * np.sin(angle), camera.yaw_deg + turn))
    return scene, EditSet(edits, rule="default"), capture.pairs(), evidence


def median_time(function, runs: int, *args):
    """Median (wall seconds, CPU seconds) over runs; CPU time shows the cost on a shared machine."""
    walls, cpus, result = [], [], None
    for _ in range(runs):
        start, start_cpu = time.perf_counter(), time.process_time()
        result = function(*args)
        walls.append(time.perf_counter() - start)
        cpus.append(time.process_time() - start_cpu)
    return (statistics.median(walls), statistics.median(cpus)), result


def bench_synthetic(count: int, neighbours: int, runs: int, moved_share: float = 1.0) -> None:
    scene, edits, pairs, evidence = synthetic_capture(count, neighbours, 0, moved_share)
    matches = sum(len(m) for m in evidence.matches.values())
    print(f"{count} cameras, {len(pairs)} pairs, {matches} inlier matches, "
          f"{len(edits.cameras)} cameras moved")
    placements = {e.image_id: e for e in edits.cameras}
    tolerances = Tolerances()
    frusta = placed_frusta(scene, placements)
    tested = tested_pairs(pairs, placements, frusta)
    steps = {
        "flat matches": lambda: ev.flat_matches(evidence, tested),
        "3D motions": lambda: motions_of(scene, placements, evidence),
    }
    flat, motions = ev.flat_matches(evidence, tested), motions_of(scene, placements, evidence)
    steps |= {
        "frustum test": lambda: frustum_test(tested, frusta),
        "match-placement test": lambda: placement_test(flat, motions, evidence, tolerances),
        "relative-pose test": lambda: relative_pose_test(flat, motions, evidence, tolerances),
        "relative-rotation test": lambda: rotation_test(flat, motions, evidence, tolerances),
        "whole rule (prune_pairs)": lambda: prune_pairs(scene, edits, pairs, evidence),
    }
    print(f"  {'step':<26} {'wall s':>8} {'cpu s':>8}")
    for name, step in steps.items():
        (wall, cpu), _ = median_time(step, runs)
        print(f"  {name:<26} {wall:8.3f} {cpu:8.3f}")
    result = prune_pairs(scene, edits, pairs, evidence)
    print(f"  deleted {len(result.deleted)} pairs; by test {result.removed_by_test}")


def bench_gather(root: Path, runs: int) -> None:
    workspace = Workspace(root)
    pairs = workspace.verified_pairs()
    ids = [c.image_id for c in workspace.scene().cameras if c.registered]
    (seconds, cpu), evidence = median_time(
        lambda: ev.gather(workspace.require(), workspace.model_dir(), partners_of_moved(pairs, set(ids))),
        runs)
    print(f"gather evidence from {root}: {len(evidence.rows)} images, {len(evidence.matches)} pairs, "
          f"{len(evidence.rays)} keypoints: {seconds:.3f} s wall, {cpu:.3f} s cpu")


def bench_preview(root: Path, moved: int, runs: int) -> None:
    workspace = Workspace(root)
    registered = [c for c in workspace.scene().cameras if c.registered]
    start = max(0, len(registered) // 2 - moved // 2)
    edits = EditSet([CameraEdit(c.image_id, c.x + 0.3, c.y, c.yaw_deg + 10.0)
                     for c in registered[start:start + moved]], rule="default")
    (seconds, cpu), outcome = median_time(workspace.preview, runs, edits)
    print(f"preview in {root}: {len(registered)} registered cameras, {len(workspace.verified_pairs())} "
          f"pairs, {len(edits.cameras)} moved: {seconds:.3f} s wall, {cpu:.3f} s cpu "
          f"(target <= 1 s); {len(outcome.deleted)} pairs cut")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3, help="runs per timing (median reported)")
    parser.add_argument("--cameras", type=int, default=300)
    parser.add_argument("--neighbours", type=int, default=30)
    parser.add_argument("--moved-share", type=float, default=1.0,
                        help="below 1: that share of the cameras moved, in four stretches")
    parser.add_argument("--workspace", type=Path, default=None)
    parser.add_argument("--moved", type=int, default=50, help="cameras moved in --workspace's preview")
    args = parser.parse_args()
    bench_synthetic(args.cameras, args.neighbours, args.runs, args.moved_share)
    if args.workspace:
        bench_gather(args.workspace, args.runs)
        bench_preview(args.workspace, args.moved, args.runs)


if __name__ == "__main__":
    main()
