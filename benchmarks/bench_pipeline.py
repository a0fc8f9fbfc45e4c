"""Time each pipeline stage on a rendered sample: render, extract, match, map, scene, prune,
warm and cold re-map. Run: .venv/bin/python benchmarks/bench_pipeline.py [--layout murals]

Prints one table (seconds per stage) on stdout; the figures depend on the machine's load.
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
from pathlib import Path

import PIL.Image  # noqa: F401  (before pycolmap: see the Pillow pitfall in cli.py)

from guided_sfm import sample
from guided_sfm.core import evaluation, simulated_user, workspace
from guided_sfm.core.sfm import SfmOptions, set_colmap_verbosity
from guided_sfm.core.stage_clock import StageClock
from guided_sfm.core.truth import load_truth
from guided_sfm.core.types import EditSet


def run(layout: str, out: Path) -> dict[str, float]:
    clock = StageClock()
    with clock.timed("render"):
        sample.write_sample(out / "sample", layout, seed=0)
    workspace.reconstruct(out / "sample" / "images", out / "ws0", SfmOptions(), clock)
    with clock.timed("scene"):
        (out / "ws0" / workspace.SCENE).unlink()
        scene = workspace.load_scene(out / "ws0")
    truth = load_truth(out / "sample" / "truth.json")
    status = evaluation.camera_status(out / "ws0", truth)
    edits = EditSet(simulated_user.place_cameras(scene, truth, status.wrong,
                                                 status.truth_from_model), rule="paper")
    with clock.timed("prune"):
        workspace.prune(out / "ws0", edits, out / "ws1")
    shutil.copytree(out / "ws1", out / "ws1-cold")
    with clock.timed("re-map warm"):
        report = workspace.map_again(out / "ws1")
    with clock.timed("re-map cold"):
        workspace.map_again(out / "ws1-cold", cold=True)
    seconds = clock.take()
    seconds["moved cameras"] = len(edits.cameras)
    seconds["warm fell back"] = report.fallback or "no"
    return seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--layout", default=sample.DEFAULT_LAYOUT)
    args = parser.parse_args()
    set_colmap_verbosity(False)
    with tempfile.TemporaryDirectory() as tmp:
        seconds = run(args.layout, Path(tmp))
    print(f"pipeline stages on the '{args.layout}' sample (seconds)")
    for stage, value in seconds.items():
        print(f"  {stage:<16} {value}")


if __name__ == "__main__":
    main()
