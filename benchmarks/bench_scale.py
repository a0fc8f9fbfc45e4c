"""Matching at scale on the rendered hall (identical bays along both walls, one outward-looking
loop): `auto` against `exhaustive` (and `retrieval` forced) at the sizes this machine affords.

Run: nice -n 10 .venv/bin/python benchmarks/bench_scale.py [--layouts hall hall-120]
     [--matchers auto exhaustive retrieval] [--resolutions 640x480 4000x3000] [--views N]
     [--max-image-sizes 0 1600] [--work DIR] [--json]

Per layout and matcher: seconds and peak memory (MiB) per stage (extract, match, map), pairs
matched, verified pairs, registered, models and wrong cameras against the truth, with the load
average read before and after each run (2 cores shared: figures swing with the load), and one
rough correction round from each reconstruction (the demo's simulated user places the wrong
cameras; fixed, wrong after, seconds of prune and warm map; --no-round skips it). Where
`auto` resolves to a matcher already run on that layout, its figures are that run's, said so.
With --work the renders are kept and reused; without it everything goes to a temp dir.

--resolutions renders the layouts at real photo sizes too (the 640x480 camera scaled: same field
of view; a render per resolution, kept under --work), --views keeps the first N views in capture
order (12 Mpx renders take about a minute each here), --max-image-sizes runs SIFT on the image
scaled down to that longest side (COLMAP's `max_image_size`; default the product's, 1600; 0 is
COLMAP's own, 3200). Each row
also gives the mean features kept per image (keypoints: SIFT keeps up to two orientations a
location, so above the budget), the matching seconds per candidate pair and the CPU seconds per
stage (the figure that swings least with the other engineers' load).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

import PIL.Image  # noqa: F401  (before pycolmap: see the Pillow pitfall in cli.py)

from guided_sfm import sample
from guided_sfm.core import colmap_db, evaluation, sfm
from guided_sfm.core.errors import EmptyModel
from guided_sfm.core.sfm import RunContext, SfmOptions
from guided_sfm.core.stage_clock import StageClock
from guided_sfm.core.workspace import Workspace
from guided_sfm.demo import run_demo


def load() -> str:
    return " ".join(f"{v:.1f}" for v in os.getloadavg())


def resolution_arg(text: str) -> tuple[int, int]:
    """WIDTHxHEIGHT, e.g. 4000x3000."""
    width, _, height = text.lower().partition("x")
    try:
        return int(width), int(height)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not WIDTHxHEIGHT") from None


def render_name(layout: str, resolution: tuple[int, int] | None = None,
                views: int | None = None) -> str:
    """Where a render is kept under --work: the layout, its slice and its resolution (none for
    the layout's own camera, so earlier caches stay valid)."""
    slice_ = f"-first{views}" if views else ""
    size = f"@{resolution[0]}x{resolution[1]}" if resolution else ""
    return f"{layout}{slice_}{size}"


def rendered(layout: str, work: Path, resolution: tuple[int, int] | None = None,
             views: int | None = None) -> Path:
    """The layout's render under work (reused when complete), at a resolution (the layout's
    camera scaled, same field of view) and cut to its first views if asked."""
    out = work / render_name(layout, resolution, views)
    if not (out / "truth.json").is_file():
        print(f"rendering {out.name} ...", file=sys.stderr, flush=True)
        started = time.perf_counter()
        sample.write_sample(out, layout, seed=0, resolution=resolution, views=views)
        print(f"rendered {out.name} in {time.perf_counter() - started:.0f} s (load {load()})",
              file=sys.stderr, flush=True)
    return out


class CpuClock:
    """CPU seconds of this process (all its threads) per stage, from the progress reports: on a
    shared machine the wall seconds swing with the load, the CPU seconds much less."""

    def __init__(self) -> None:
        self.seconds: dict[str, float] = {}
        self._stage, self._since = "", 0.0

    def __call__(self, stage: str, fraction: float) -> None:
        if stage != self._stage:
            self.stop()
            self._stage, self._since = stage, time.process_time()

    def stop(self) -> dict[str, float]:
        if self._stage:
            elapsed = time.process_time() - self._since
            self.seconds[self._stage] = self.seconds.get(self._stage, 0.0) + elapsed
        self._stage = ""
        return self.seconds


def run_one(images: Path, out: Path, options: SfmOptions) -> dict:
    """One full reconstruction with these options; its figures."""
    cpu = CpuClock()
    load_before, clock = load(), StageClock(cpu)
    workspace = Workspace(out)
    workspace.reconstruct(images / "images", RunContext(options, clock))
    report, cpu_seconds = clock.report(), cpu.stop()
    status = evaluation.evaluate_workspace(workspace, images / "truth.json")
    stats = workspace.stats()
    keypoints = colmap_db.keypoint_counts(workspace.database).values()
    return {"matcher": options.matcher, "used": workspace.used()["matcher"],
            "pairs": workspace.used()["pairs"], "verified": stats["num_pairs"],
            "registered": stats["num_registered"], "images": stats["num_images"],
            "models": stats["num_models"], "wrong": status["num_wrong"],
            "features": round(sum(keypoints) / max(len(keypoints), 1)),
            "stages": {s["stage"]: (s["seconds"], s["peak_mb"]) for s in report["stages"]},
            "cpu": {stage: round(seconds, 1) for stage, seconds in cpu_seconds.items()},
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


def measure(layout: str, matchers: list[str], work: Path, round_: bool = True,
            resolution: tuple[int, int] | None = None, views: int | None = None,
            max_image_size: int | None = None) -> list[dict]:
    images = rendered(layout, work, resolution, views)
    name = render_name(layout, resolution, views)
    size = "x".join(map(str, resolution)) if resolution else "own"
    count = len(sfm.list_images(images / "images"))
    done: dict[str, dict] = {}
    rows = []
    for matcher in matchers:
        used = sfm.matcher_for(matcher, count)
        if used in done:
            rows.append({**done[used], "matcher": matcher, "note": f"same run as {used}"})
            continue
        print(f"{name} ({count} images, max image size {max_image_size or 'COLMAP 3200'}): "
              f"{matcher} ...", file=sys.stderr, flush=True)
        out = work / f"{name}-{matcher}{f'-max{max_image_size}' if max_image_size else ''}"
        shutil.rmtree(out, ignore_errors=True)  # a kept tree would hide the cost of building one
        options = SfmOptions(matcher=matcher, max_image_size=max_image_size)
        done[used] = row = {**run_one(images, out, options), "layout": layout,
                            "resolution": size, "max_size": max_image_size or 0}
        if round_:
            row.update(correction_round(images, out, work / f"{out.name}-round"))
        rows.append(row)
    return rows


def print_rows(rows: list[dict]) -> None:
    print(f"auto is exhaustive up to {sfm.AUTO_EXHAUSTIVE_MAX_IMAGES} images, retrieval above; "
          "max = SIFT's longest side (0: COLMAP's own, 3200); ms/pair = match s / pairs")
    print(f"{'layout':<9} {'resolution':<10} {'max':>4} {'matcher':<10} {'used':<10} {'imgs':>4} "
          f"{'feats':>5} {'pairs':>6} {'verif':>6} {'reg':>4} {'wrong':>5} {'mod':>3}  "
          f"{'extract s/MiB':>13} {'match s/MiB':>13} {'map s/MiB':>13} {'total':>6} "
          f"{'ms/pair':>7}  load (1/5/15 min) before -> after")
    for r in rows:
        cells = [f"{r['stages'].get(k, (0, 0))[0]:6.1f}/{r['stages'].get(k, (0, 0))[1]:<6.0f}"
                 for k in ("extract", "match", "map")]
        per_pair = 1000 * r["stages"].get("match", (0, 0))[0] / max(r["pairs"], 1)
        print(f"{r['layout']:<9} {r['resolution']:<10} {r['max_size']:4d} {r['matcher']:<10} "
              f"{r['used']:<10} {r['images']:4d} {r['features']:5d} {r['pairs']:6d} "
              f"{r['verified']:6d} {r['registered']:4d} {r['wrong']:5d} {r['models']:3d}  "
              f"{cells[0]:>13} {cells[1]:>13} {cells[2]:>13} {r['seconds']:6.1f} {per_pair:7.1f}"
              f"  {r['load']}{'  (' + r['note'] + ')' if 'note' in r else ''}")
        if "cpu" in r and "note" not in r:
            print(f"{'':<9} {'':<10} CPU s (all threads): "
                  + ", ".join(f"{stage} {seconds:.1f}" for stage, seconds in r["cpu"].items()))
        if "round" in r and "note" not in r:
            print(f"{'':<9} {'':<10} one correction round: {r['round']}")


def sizes_that_differ(sizes: list[int], resolution: tuple[int, int] | None) -> list[int]:
    """The max image sizes that give different runs at this resolution: every size at or above
    the images' longest side leaves them as they are (the same features), so only the first of
    those runs (at the layout's own camera, whose size is not known here, all run)."""
    if resolution is None:
        return sizes
    binding = [size for size in sizes if 0 < size < max(resolution)]
    free = [size for size in sizes if size not in binding][:1]
    return [size for size in sizes if size in binding or size in free]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--layouts", nargs="+", default=["hall", "hall-120"])
    parser.add_argument("--matchers", nargs="+", default=["auto", "exhaustive", "retrieval"])
    parser.add_argument("--work", default=None, help="keep and reuse renders and workspaces here")
    parser.add_argument("--resolutions", nargs="+", type=resolution_arg, default=[None],
                        help="render at these WIDTHxHEIGHT (the layout's camera scaled, same "
                             "field of view; default: its own 640x480)")
    parser.add_argument("--views", type=int, default=None,
                        help="only the first N views in capture order (a slice of the layout)")
    parser.add_argument("--max-image-sizes", nargs="+", type=int,
                        default=[sfm.DEFAULT_MAX_IMAGE_SIZE],
                        help="SIFT's longest side, one run each (default: the product's "
                             f"{sfm.DEFAULT_MAX_IMAGE_SIZE}; 0: COLMAP's own, 3200); sizes at or "
                             "above a resolution's longest side run once there")
    parser.add_argument("--no-round", action="store_true", help="skip the correction round")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    sfm.set_colmap_verbosity(False)
    with tempfile.TemporaryDirectory(prefix="bench-scale-") as tmp:
        work = Path(args.work or tmp)
        work.mkdir(parents=True, exist_ok=True)
        rows = [row for layout in args.layouts for resolution in args.resolutions
                for size in sizes_that_differ(args.max_image_sizes, resolution)
                for row in measure(layout, args.matchers, work, not args.no_round, resolution,
                                   args.views, size or None)]
    print_rows(rows)
    if args.json:
        print(json.dumps(rows))


if __name__ == "__main__":
    main()
