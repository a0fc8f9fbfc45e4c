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
from guided_sfm.core import evaluation, simulated_user
from guided_sfm.core.sfm import RunContext, set_colmap_verbosity
from guided_sfm.core.stage_clock import StageClock
from guided_sfm.core.truth import load_truth
from guided_sfm.core.types import EditSet
from guided_sfm.core.workspace import Workspace


def run(layout: str, out: Path) -> dict[str, float]:
    clock = StageClock()
    with clock.timed("render"):
        sample.write_sample(out / "sample", layout, seed=0)
    ws0, ws1, cold = Workspace(out / "ws0"), Workspace(out / "ws1"), Workspace(out / "ws1-cold")
    ws0.reconstruct(out / "sample" / "images", RunContext(progress=clock))
    with clock.timed("scene"):
        ws0.scene_file.unlink()
        scene = ws0.scene()
    truth = load_truth(out / "sample" / "truth.json")
    status = evaluation.camera_status(ws0, truth)
    edits = EditSet(simulated_user.place_cameras(scene, truth, status.wrong,
                                                 status.truth_from_model), rule="paper")
    with clock.timed("prune"):
        ws0.prune(edits, ws1)
    shutil.copytree(ws1.root, cold.root)
    with clock.timed("re-map warm"):
        report = ws1.map_again()
    with clock.timed("re-map cold"):
        cold.map_again(cold=True)
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
