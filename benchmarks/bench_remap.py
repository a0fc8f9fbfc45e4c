"""Warm against cold re-mapping after a correction, timed side by side.

Run: .venv/bin/python benchmarks/bench_remap.py [--layouts murals,office,twins,orbit]
                                                [--sizes 150,300] [--halls 1000] [--runs 3]
                                                [--moved 3] [--moved-run]

- Sample layouts: render, reconstruct, let the demo's simulated user place the wrong cameras
  (default rule), prune once; then map the pruned workspace cold and warm, interleaved
  (cold, warm, cold, warm, ...), each run on a fresh copy made outside the timed region.
- Synthetic scenes (pycolmap.synthesize_dataset, N images, each matched with ~30 others): a
  cold map is the base version; the edit moves --moved cameras, spread evenly over the image ids
  (3: at the quartiles; 50 of 1,000: the issue's 5%), or a run of consecutive ids with
  --moved-run (a fold is a run of the capture); their pairs are kept (nothing to prune); then the
  database is mapped cold and warm (from the base without the moved ones), interleaved.
  (synthesize_dataset at 1,000 images ran for over 6 CPU minutes without finishing: at that
  size use --halls.)
- Synthetic halls (--halls N, none by default): benchmarks/synthetic_workspace.py's walked hall
  of N cameras, its model the truth and the base version; then as the synthetic scenes (the
  issue's figure: --halls 1000 --moved 50 --moved-run).
Per scene: median seconds of each, the ratio, the registered count and models of both, and the
median rotation MAE (deg) of the moved cameras against the truth for both. With --prior, sample
layouts are also mapped warm with the round's placements as position priors (SfmOptions.
placement_prior), interleaved with the others, so "warm" (without) and "prior" (with) compare
in the same run. The figures depend on the
machine's load; the ratios compare runs made side by side.
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import PIL.Image  # noqa: F401  (before pycolmap: see the Pillow pitfall in cli.py)
import pycolmap

from guided_sfm import sample
from guided_sfm.core import colmap_model, evaluation, metrics, remap, sfm, simulated_user
from guided_sfm.core.sfm import set_colmap_verbosity
from guided_sfm.core.truth import load_truth
from guided_sfm.core.types import EditSet
from guided_sfm.core.workspace import Workspace

sys.path.insert(0, str(Path(__file__).resolve().parent))
from synthetic_workspace import write_workspace  # noqa: E402

TARGETS = {"layout": 1.8, "synthetic": 5.0}
MAX_MAE_GAP_DEG = 0.1
SYNTHETIC_POINTS, SYNTHETIC_PARTNERS = 600, 30


def rotation_mae(models: list, truth: dict, names: list[str]) -> float:
    """Mean rotation error (deg) of the named cameras after a similarity on all common centres."""
    est = colmap_model.camera_poses(models[0])
    common = sorted(set(est) & set(truth))
    src, dst = (np.array([poses[n][1] for n in common]) for poses in (est, truth))
    extent = float(np.linalg.norm(dst.max(axis=0) - dst.min(axis=0)))
    sim = metrics.align_similarity(src, dst, threshold=0.02 * extent)  # inliers: within 2% of the scene
    errors = metrics.camera_errors({n: est[n] for n in names if n in est}, truth, sim)
    return statistics.fmean(e.rotation_deg for e in errors.values()) if errors else float("nan")


# A run of a mode (cold, warm or prior) returns (seconds of the mapping alone, models, MapReport);
# copies happen outside the clock.
Run = Callable[[str], tuple[float, list, remap.MapReport]]


def interleaved(runs: int, run: Run, truth: dict, moved_names: list[str],
                modes: tuple[str, ...] = ("cold", "warm")) -> dict:
    """Per mode: median seconds and MAE, the last run's registration and models (cold, warm, ...).

    Cold maps are not deterministic on 2 threads (their MAE varies between runs), hence medians.
    """
    seconds: dict[str, list[float]] = {mode: [] for mode in modes}
    maes: dict[str, list[float]] = {mode: [] for mode in modes}
    out = {}
    for _ in range(runs):
        for mode in seconds:
            took, models, report = run(mode)
            seconds[mode].append(took)
            maes[mode].append(rotation_mae(models, truth, moved_names))
            out[mode] = {"registered": models[0].num_reg_images(), "models": len(models),
                         "fallback": report.fallback}
    for mode in seconds:
        measured = [mae for mae in maes[mode] if not np.isnan(mae)]  # NaN: moved ones unregistered
        out[mode].update(median=statistics.median(seconds[mode]),
                         mae=statistics.median(measured) if measured else float("nan"))
    return out


def layout_scene(layout: str, runs: int, root: Path, prior: bool = False) -> dict:
    """The demo's first correction of a rendered layout, mapped again cold and warm."""
    sample.write_sample(root / "sample", layout, seed=0)
    ws0, ws1 = Workspace(root / "ws0"), Workspace(root / "ws1")
    ws0.reconstruct(root / "sample" / "images")
    truth = load_truth(root / "sample" / "truth.json")
    status = evaluation.camera_status(ws0, truth)
    targets = [n for n in status.wrong + status.unregistered if n in truth.cameras]
    edits = EditSet(simulated_user.place_cameras(ws0.scene(), truth, targets,
                                                 status.truth_from_model, 1), rule="default")
    ws0.prune(edits, ws1)
    names = ws1.image_ids()
    moved = {c.image_id for c in edits.cameras}

    def run(mode: str) -> tuple[float, list, remap.MapReport]:
        copy = Workspace(root / "run")
        shutil.rmtree(copy.root, ignore_errors=True)
        shutil.copytree(ws1.root, copy.root)
        options = sfm.SfmOptions(placement_prior=mode == "prior")
        start = time.perf_counter()
        report = copy.map_again(sfm.RunContext(options), cold=mode == "cold")
        took = time.perf_counter() - start
        return took, copy.load_models(), report

    truth_poses = {n: (c.rotation, c.center) for n, c in truth.cameras.items()}
    moved_names = [n for n, i in names.items() if i in moved]
    modes = ("cold", "warm", "prior") if prior else ("cold", "warm")
    return {"scene": f"{layout} sample", "images": len(names), "moved": len(moved),
            **interleaved(runs, run, truth_poses, moved_names, modes)}


def moved_ids(ids: list[int], count: int, run: bool) -> set[int]:
    """`count` of the ids: spread evenly (3 of them: at the quartiles), or consecutive ones from
    the first quarter on when `run`."""
    if run:
        start = len(ids) // 4
        return set(ids[start : start + count])
    return {ids[k * len(ids) // (count + 1)] for k in range(1, count + 1)}


def synthetic_scene(size: int, runs: int, root: Path, moved_count: int = 3,
                    moved_run: bool = False) -> dict:
    """A synthesized walk of `size` images: its cold map is the base, then `moved_count` cameras
    are edited."""
    pycolmap.set_random_seed(0)
    # ~30 matched partners per image (SPARSE drops the rest at random) and 600 points: a 150-image
    # database of ~35 MB; every pair matched with every point wrote 1.5 GB.
    options = pycolmap.SyntheticDatasetOptions(
        num_rigs=1, num_cameras_per_rig=1, num_frames_per_rig=size, num_points3D=SYNTHETIC_POINTS,
        match_config=pycolmap.SyntheticDatasetMatchConfig.SPARSE,
        match_sparsity=max(0.0, 1.0 - SYNTHETIC_PARTNERS / size))
    database = root / "database.db"
    db = pycolmap.Database.open(str(database))
    truth_model = pycolmap.synthesize_dataset(options, db)
    db.close()
    (root / "images").mkdir()  # no pixels: mapping reads keypoints and matches only
    base = sfm.map_database(database, root / "images", root / "base")
    ids = sorted(base[0].reg_image_ids())
    moved = moved_ids(ids, moved_count, moved_run)
    return {"scene": f"synthetic {size}", "images": size, "moved": len(moved),
            **_warm_and_cold(database, root, base, moved, runs, colmap_model.camera_poses(truth_model))}


def hall_scene(size: int, runs: int, root: Path, moved_count: int = 50,
               moved_run: bool = False) -> dict:
    """benchmarks/synthetic_workspace.py's walked hall of `size` cameras (200 model points per
    camera, 30 capture-order partners each): its model is the truth and the base (the editor's
    1,000-camera scene, issue 22); then `moved_count` cameras are edited."""
    write_workspace(root / "ws", cameras=size, points=200 * size)
    workspace = Workspace(root / "ws")
    base = workspace.load_models()[0]
    for point_id in [i for i, point in base.points3D.items() if point.track.length() < 2]:
        base.delete_point3D(point_id)  # points no two cameras see: bundle adjustment refuses them
    moved = moved_ids(sorted(base.reg_image_ids()), moved_count, moved_run)
    return {"scene": f"synthetic hall {size}", "images": size, "moved": len(moved),
            **_warm_and_cold(workspace.database, root, [base], moved, runs,
                             colmap_model.camera_poses(base))}


def _warm_and_cold(database: Path, root: Path, base: list, moved: set[int], runs: int,
                   truth: dict) -> dict:
    """The database mapped cold and warm (from base without the moved images), interleaved."""
    (root / "images").mkdir(exist_ok=True)  # no pixels: mapping reads keypoints and matches only

    def run(mode: str) -> tuple[float, list, remap.MapReport]:
        shutil.rmtree(root / "run", ignore_errors=True)
        start = time.perf_counter()
        models, report = remap.map_warm_or_cold(database, root / "images", root / "run", base, moved,
                                                cold=mode == "cold")
        return time.perf_counter() - start, models, report

    return interleaved(runs, run, truth, [base[0].image(i).name for i in moved])


def print_header(runs: int) -> None:
    print(f"warm against cold re-mapping, median of {runs} runs each, interleaved")
    print(f"{'scene':<18} {'images':>6} {'moved':>5} {'cold s':>7} {'warm s':>7} {'ratio':>6} "
          f"{'reg c/w':>8} {'models c/w':>10} {'MAE c/w deg':>13}  warm fell back", flush=True)


def print_row(r: dict) -> None:
    """One scene's figures, printed as soon as it is measured (the whole run takes long)."""
    cold, warm = r["cold"], r["warm"]
    print(f"{r['scene']:<18} {r['images']:>6} {r['moved']:>5} {cold['median']:7.1f} "
          f"{warm['median']:7.1f} "
          f"{cold['median'] / warm['median']:5.1f}x {cold['registered']:>3}/{warm['registered']:<4} "
          f"{cold['models']:>5}/{warm['models']:<4} {cold['mae']:6.2f}/{warm['mae']:<6.2f}  "
          f"{warm['fallback'] or 'no'}", flush=True)
    if "prior" in r:
        prior = r["prior"]
        print(f"{'  held to priors':<30} {prior['median']:7.1f} s (warm without: "
              f"{warm['median']:.1f} s, {warm['median'] / prior['median']:.2f}x), registered "
              f"{prior['registered']}, models {prior['models']}, MAE {prior['mae']:.2f} deg, "
              f"fell back: {prior['fallback'] or 'no'}", flush=True)


def print_checks(rows: list[dict]) -> None:
    for r in rows:
        cold, warm = r["cold"], r["warm"]
        target = TARGETS["synthetic" if r["scene"].startswith("synthetic") else "layout"]
        checks = {f"warm >= {target}x": cold["median"] / warm["median"] >= target,
                  "same registered": warm["registered"] >= cold["registered"],
                  "no split": warm["models"] <= cold["models"],
                  f"MAE <= cold + {MAX_MAE_GAP_DEG} deg": warm["mae"] - cold["mae"] <= MAX_MAE_GAP_DEG}
        print(f"  {r['scene']:<18} " + ", ".join(f"{'PASS' if ok else 'FAIL'} {name}"
                                                  for name, ok in checks.items()))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    parser.add_argument("--layouts", default="murals,office,twins,orbit")
    parser.add_argument("--sizes", default="150,300")
    parser.add_argument("--halls", default="",
                        help="sizes of synthetic_workspace.py's hall, e.g. 1000 (none by default)")
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--moved", type=int, default=3,
                        help="cameras the synthetic scenes' edit moves (spread evenly)")
    parser.add_argument("--moved-run", action="store_true",
                        help="move a run of consecutive images instead")
    parser.add_argument("--prior", action="store_true",
                        help="also map the layouts warm held to the placements' priors")
    args = parser.parse_args()
    set_colmap_verbosity(False)
    rows = []
    print_header(args.runs)
    for layout in filter(None, args.layouts.split(",")):
        with tempfile.TemporaryDirectory(prefix="bench-remap-") as tmp:
            rows.append(layout_scene(layout, args.runs, Path(tmp), args.prior))
        print_row(rows[-1])
    for size in (int(s) for s in filter(None, args.sizes.split(","))):
        with tempfile.TemporaryDirectory(prefix="bench-remap-") as tmp:
            rows.append(synthetic_scene(size, args.runs, Path(tmp), args.moved, args.moved_run))
        print_row(rows[-1])
    for size in (int(s) for s in filter(None, args.halls.split(","))):
        with tempfile.TemporaryDirectory(prefix="bench-remap-") as tmp:
            rows.append(hall_scene(size, args.runs, Path(tmp), args.moved, args.moved_run))
        print_row(rows[-1])
    print_checks(rows)


if __name__ == "__main__":
    main()
