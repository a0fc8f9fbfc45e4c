"""Matching at scale on the rendered hall (identical bays along both walls, one outward-looking
loop): `auto` against `exhaustive` (and `retrieval` forced) at the sizes this machine affords.

Run: nice -n 10 .venv/bin/python benchmarks/bench_scale.py [--layouts hall hall-120]
     [--matchers auto exhaustive retrieval] [--work DIR] [--json]

Per layout and matcher: seconds and peak memory (MiB) per stage (extract, match, map), pairs
matched, verified pairs, registered, models and wrong cameras against the truth, with the load
average read before and after each run (2 cores shared: figures swing with the load). Where
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
from guided_sfm.core.sfm import RunContext, SfmOptions
from guided_sfm.core.stage_clock import StageClock
from guided_sfm.core.workspace import Workspace


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


def measure(layout: str, matchers: list[str], work: Path) -> list[dict]:
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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--layouts", nargs="+", default=["hall", "hall-120"])
    parser.add_argument("--matchers", nargs="+", default=["auto", "exhaustive", "retrieval"])
    parser.add_argument("--work", default=None, help="keep and reuse renders and workspaces here")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    sfm.set_colmap_verbosity(False)
    with tempfile.TemporaryDirectory(prefix="bench-scale-") as tmp:
        work = Path(args.work or tmp)
        work.mkdir(parents=True, exist_ok=True)
        rows = [row for layout in args.layouts for row in measure(layout, args.matchers, work)]
    print_rows(rows)
    if args.json:
        print(json.dumps(rows))


if __name__ == "__main__":
    main()
