"""Matching at scale on the rendered hall (identical bays along both walls, one outward-looking
loop): `auto` against `exhaustive` (and `retrieval` forced) at the sizes this machine affords.

Run: nice -n 10 .venv/bin/python benchmarks/bench_scale.py [--layouts hall hall-120]
     [--matchers auto exhaustive retrieval] [--work DIR] [--json]

Per layout and matcher: seconds and peak memory (MiB) per stage (extract, match, map), pairs
matched, verified pairs, registered, models and wrong cameras against the truth, with the load
average read before and after each run (2 cores shared: figures swing with the load), and one
rough correction round from each reconstruction (the demo's simulated user places the wrong
cameras; fixed, wrong after, seconds of prune and warm map; --no-round skips it). Where
`auto` resolves to a matcher already run on that layout, its figures are that run's, said so.
With --work the renders are kept and reused; without it everything goes to a temp dir.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
from pathlib import Path

import PIL.Image  # noqa: F401  (before pycolmap: see the Pillow pitfall in cli.py)

from guided_sfm import sample
from guided_sfm.core import evaluation, sfm
from guided_sfm.core.errors import EmptyModel
from guided_sfm.core.sfm import RunContext, SfmOptions
from guided_sfm.core.stage_clock import StageClock
from guided_sfm.core.workspace import Workspace
from guided_sfm.demo import run_demo


def load() -> str:
    return " ".join(f"{v:.1f}" for v in os.getloadavg())


def rendered(layout: str, work: Path) -> Path:
    """The layout's render under work (reused when complete)."""
    out = work / layout
    if not (out / "truth.json").is_file():
        print(f"rendering {layout} ...", file=sys.stderr, flush=True)
        sample.write_sample(out, layout, seed=0)
    return out


def run_one(images: Path, out: Path, matcher: str) -> dict:
    """One full reconstruction with this matcher; its figures."""
    load_before, clock = load(), StageClock()
    workspace = Workspace(out)
    workspace.reconstruct(images / "images", RunContext(SfmOptions(matcher=matcher), clock))
    report = clock.report()
    status = evaluation.evaluate_workspace(workspace, images / "truth.json")
    stats = workspace.stats()
    return {"matcher": matcher, "used": workspace.used()["matcher"],
            "pairs": workspace.used()["pairs"], "verified": stats["num_pairs"],
            "registered": stats["num_registered"], "images": stats["num_images"],
            "models": stats["num_models"], "wrong": status["num_wrong"],
            "stages": {s["stage"]: (s["seconds"], s["peak_mb"]) for s in report["stages"]},
            "seconds": report["seconds"], "load": f"{load_before} -> {load()}"}


def correction_round(images: Path, workspace: Path, out: Path) -> dict:
    """One round of the demo's loop started from this reconstruction (run_demo reuses round0)."""
    shutil.rmtree(out, ignore_errors=True)
    out.mkdir(parents=True)
    (out / "sample").symlink_to(images.resolve())
    shutil.copytree(workspace, out / "round0")
    try:
        result = run_demo(rounds=1, rule="default", out_dir=out, reuse=True)
    except EmptyModel as exc:  # e.g. too few right cameras to align with the truth
        return {"round": f"stopped: {exc}"}
    summary, rounds = result["summary"], result["rounds"]
    if len(rounds) == 1:
        return {"round": "nothing to correct"}
    seconds = rounds[-1]["seconds"]
    return {"round": f"of {summary['initially_wrong']} wrong + {summary['initially_unregistered']}"
                     f" unregistered, {summary['fixed']} fixed, {summary['remaining']} not right"
                     f" after ({summary['final_wrong']} wrong, {summary['final_models']} models);"
                     f" prune {seconds.get('prune', 0):.1f} s, warm map {seconds.get('map', 0):.1f} s"}


def measure(layout: str, matchers: list[str], work: Path, round_: bool = True) -> list[dict]:
    images = rendered(layout, work)
    count = len(sfm.list_images(images / "images"))
    done: dict[str, dict] = {}
    rows = []
    for matcher in matchers:
        used = sfm.matcher_for(matcher, count)
        if used in done:
            rows.append({**done[used], "matcher": matcher, "note": f"same run as {used}"})
            continue
        print(f"{layout} ({count} images): {matcher} ...", file=sys.stderr, flush=True)
        out = work / f"{layout}-{matcher}"
        shutil.rmtree(out, ignore_errors=True)  # a kept tree would hide the cost of building one
        done[used] = row = {**run_one(images, out, matcher), "layout": layout}
        if round_:
            row.update(correction_round(images, out, work / f"{layout}-{matcher}-round"))
        rows.append(row)
    return rows


def print_rows(rows: list[dict]) -> None:
    print(f"auto is exhaustive up to {sfm.AUTO_EXHAUSTIVE_MAX_IMAGES} images, retrieval above")
    print(f"{'layout':<9} {'matcher':<10} {'used':<10} {'imgs':>4} {'pairs':>6} {'verif':>6} "
          f"{'reg':>4} {'wrong':>5} {'mod':>3}  {'extract s/MiB':>13} {'match s/MiB':>13} "
          f"{'map s/MiB':>13} {'total':>6}  load (1/5/15 min) before -> after")
    for r in rows:
        cells = [f"{r['stages'].get(k, (0, 0))[0]:6.1f}/{r['stages'].get(k, (0, 0))[1]:<6.0f}"
                 for k in ("extract", "match", "map")]
        print(f"{r['layout']:<9} {r['matcher']:<10} {r['used']:<10} {r['images']:4d} "
              f"{r['pairs']:6d} {r['verified']:6d} {r['registered']:4d} {r['wrong']:5d} "
              f"{r['models']:3d}  {cells[0]:>13} {cells[1]:>13} {cells[2]:>13} "
              f"{r['seconds']:6.1f}  {r['load']}{'  (' + r['note'] + ')' if 'note' in r else ''}")
        if "round" in r and "note" not in r:
            print(f"{'':<9} {'':<10} one correction round: {r['round']}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--layouts", nargs="+", default=["hall", "hall-120"])
    parser.add_argument("--matchers", nargs="+", default=["auto", "exhaustive", "retrieval"])
    parser.add_argument("--work", default=None, help="keep and reuse renders and workspaces here")
    parser.add_argument("--no-round", action="store_true", help="skip the correction round")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    sfm.set_colmap_verbosity(False)
    with tempfile.TemporaryDirectory(prefix="bench-scale-") as tmp:
        work = Path(args.work or tmp)
        work.mkdir(parents=True, exist_ok=True)
        rows = [row for layout in args.layouts for row in measure(layout, args.matchers, work,
                                                                   not args.no_round)]
    print_rows(rows)
    if args.json:
        print(json.dumps(rows))


if __name__ == "__main__":
    main()
