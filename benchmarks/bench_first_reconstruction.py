"""First reconstruction of a rendered sample: the product's default path against bare pycolmap.

Run: .venv/bin/python benchmarks/bench_first_reconstruction.py [--layout murals] [--runs 3]

Strategies, timed in the same run and interleaved (run 1 of each, then run 2 of each, ...):
- "pycolmap defaults": extract_features, match_exhaustive, incremental_mapping, every option
  left at pycolmap's default (8192 SIFT features, all cores);
- "default path": guided_sfm's reconstruct with SfmOptions() (exhaustive matching, incremental);
- the opt-in strategies: sequential matching, global mapping, COLMAP's own SIFT octaves.
Per strategy: median seconds per stage and in all, the speed-up over pycolmap defaults, registered
images and models, and the demo's outcome (`demo --rounds 2` with the default rule, started from
that strategy's first reconstruction): wrong cameras, how many were fixed, final models.
Figures depend on the machine's load; the ratios compare runs made side by side.
"""

from __future__ import annotations

import argparse
import json
import shutil
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import PIL.Image  # noqa: F401  (before pycolmap: see the Pillow pitfall in cli.py)
import pycolmap

from guided_sfm import sample
from guided_sfm.core.errors import EmptyModel
from guided_sfm.core.sfm import RunContext, SfmOptions, set_colmap_verbosity
from guided_sfm.core.stage_clock import StageClock
from guided_sfm.core.workspace import Workspace
from guided_sfm.demo import run_demo

Build = Callable[[Path, Path], dict[str, float]]


def bare_pycolmap(images: Path, out: Path) -> dict[str, float]:
    """What a user of pycolmap gets without choosing anything; shaped as a workspace afterwards."""
    workspace = Workspace(out)
    database, seconds = workspace.database, {}
    start = time.perf_counter()
    pycolmap.extract_features(database, images)
    seconds["extract"] = time.perf_counter() - start
    start = time.perf_counter()
    pycolmap.match_exhaustive(database)
    seconds["match"] = time.perf_counter() - start
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        models = pycolmap.incremental_mapping(database, images, tmp)
    seconds["map"] = time.perf_counter() - start
    for index, model in enumerate(sorted(models.values(), key=lambda m: -m.num_reg_images())):
        workspace.model_dir(index).mkdir(parents=True)
        model.write_binary(workspace.model_dir(index))
    workspace.write_meta({"image_dir": str(images.resolve())})
    workspace.write_scene()
    return seconds


def guided(options: SfmOptions) -> Build:
    def build(images: Path, out: Path) -> dict[str, float]:
        clock = StageClock()
        Workspace(out).reconstruct(images, RunContext(options, clock))
        return {s["stage"]: s["seconds"] for s in clock.report()["stages"]}

    return build


STRATEGIES: dict[str, Build] = {
    "pycolmap defaults": bare_pycolmap,
    "default path": guided(SfmOptions()),
    "sequential (opt-in)": guided(SfmOptions(matcher="sequential")),
    "global (opt-in)": guided(SfmOptions(mapper="global")),
    "colmap SIFT (opt-in)": guided(SfmOptions(features="colmap")),
}


def demo_outcome(rendered: Path, reconstruction: Path, out: Path) -> dict:
    """The demo's loop started from this reconstruction (run_demo reuses out/round0)."""
    out.mkdir()
    (out / "sample").symlink_to(rendered.resolve())
    shutil.copytree(reconstruction, out / "round0")
    try:
        summary = run_demo(rounds=2, rule="default", out_dir=out, reuse=True)["summary"]
    except EmptyModel as exc:  # e.g. no camera right to align a round with: the loop cannot start
        print(f"demo from {reconstruction.name} stopped: {exc}", file=sys.stderr)
        return {"wrong": "?", "fixed": 0, "final_models": "?", "stopped": str(exc)}
    return {"wrong": summary["initially_wrong"] + summary["initially_unregistered"],
            "fixed": summary["fixed"], "final_models": summary["final_models"]}


def _slug(name: str) -> str:
    return "-".join(name.split()[:2])


def measure(layout: str, runs: int, root: Path) -> dict[str, dict]:
    rendered = root / "sample"
    sample.write_sample(rendered, layout, seed=0)
    times: dict[str, list[dict[str, float]]] = {name: [] for name in STRATEGIES}
    results: dict[str, dict] = {}
    for run in range(runs):
        for name, build in STRATEGIES.items():
            out = root / f"{_slug(name)}-{run}"
            out.mkdir()
            times[name].append(build(rendered / "images", out))
            print(f"run {run + 1}/{runs} {name}: {sum(times[name][-1].values()):.1f} s",
                  file=sys.stderr, flush=True)
            if run == 0:
                models = Workspace(out).load_models()
                results[name] = {"registered": models[0].num_reg_images() if models else 0,
                                 "models": len(models),
                                 "demo": demo_outcome(rendered, out, root / f"demo-{_slug(name)}")}
            else:
                shutil.rmtree(out)
    for name, runs_seconds in times.items():
        stages = {stage: statistics.median(r[stage] for r in runs_seconds) for stage in runs_seconds[0]}
        results[name].update(stages=stages, total=statistics.median(sum(r.values()) for r in runs_seconds))
    return results


def print_table(layout: str, runs: int, images: int, results: dict[str, dict]) -> None:
    baseline = results["pycolmap defaults"]["total"]
    print(f"first reconstruction of the '{layout}' sample ({images} images), median of {runs} runs")
    print(f"{'strategy':<20} {'extract':>8} {'match':>8} {'map':>8} {'total':>8} {'speed-up':>8} "
          f"{'reg.':>5} {'models':>6}  demo (wrong -> fixed, final models)")
    for name, r in results.items():
        s, demo = r["stages"], r["demo"]
        print(f"{name:<20} {s.get('extract', 0):8.1f} {s.get('match', 0):8.1f} {s.get('map', 0):8.1f} "
              f"{r['total']:8.1f} {baseline / r['total']:7.2f}x {r['registered']:5d} {r['models']:6d}  "
              f"{demo['wrong']} -> {demo['fixed']}, {demo['final_models']}")
    ours, bare = results["default path"], results["pycolmap defaults"]
    checks = {"default path >= 2x faster": bare["total"] / ours["total"] >= 2.0,
              "equal registration": ours["registered"] >= bare["registered"],
              "same demo outcome (or better)": _left_wrong(ours["demo"]) <= _left_wrong(bare["demo"])}
    for check, ok in checks.items():
        print(f"  {'PASS' if ok else 'FAIL'}  {check}")


def _left_wrong(demo: dict) -> float:
    """Cameras the demo left wrong plus extra models; infinite when the loop could not start."""
    if "stopped" in demo:
        return float("inf")
    return demo["wrong"] - demo["fixed"] + demo["final_models"] - 1


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    parser.add_argument("--layout", default=sample.DEFAULT_LAYOUT)
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--json", action="store_true", help="one JSON document instead of the table")
    args = parser.parse_args()
    set_colmap_verbosity(False)
    with tempfile.TemporaryDirectory(prefix="bench-first-") as tmp:
        results = measure(args.layout, args.runs, Path(tmp))
        images = len(list((Path(tmp) / "sample" / "images").iterdir()))
    if args.json:
        print(json.dumps({"layout": args.layout, "runs": args.runs, "images": images, "results": results}))
    else:
        print_table(args.layout, args.runs, images, results)


if __name__ == "__main__":
    main()
