"""The default rule's sensitivity: the whole loop with each tolerance scaled, one at a time.

Run: .venv/bin/python benchmarks/bench_sensitivity.py [--layouts murals,office,twins,orbit,tiny]
         [--rounds 2] [--factors 0.7,1.5] [--work DIR] [--json]

Each layout is rendered and reconstructed once (kept in --work, so a second run reuses it); then
`demo --rounds N --reuse` runs with the defaults and with every tolerance of core/rule/tolerances.py
scaled by each factor, all from that same first reconstruction. Per run: the share of the
initially wrong cameras fixed, the final number of models, and the pruning pooled over the rounds
(precision, F1). The check: >= 95% fixed in one model, every run. A --work folder is reused as it
is: delete it after a sample layout changes. With rotation_min_inliers at 15 (COLMAP's own bound
for a verified pair) its 0.7x setting changes nothing.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import PIL.Image  # noqa: F401  (before pycolmap: see the Pillow pitfall in cli.py)

from guided_sfm.core.rule.tolerances import NAMES, Tolerances
from guided_sfm.core.sfm import set_colmap_verbosity
from guided_sfm.demo import run_demo

TARGET_FIXED = 0.95


def one_run(layout: str, work: Path, rounds: int, overrides: dict[str, float]) -> dict:
    result = run_demo(layout, rounds=rounds, out_dir=work / layout, tolerances=overrides,
                      reuse=True)
    summary = result["summary"]
    wrong = summary["initially_wrong"] + summary["initially_unregistered"]
    pooled = summary["pruning_pooled"] or {}
    return {"fixed": summary["fixed"], "wrong": wrong,
            "share": summary["fixed"] / wrong if wrong else 1.0,
            "models": summary["final_models"],
            "precision": pooled.get("precision"), "f1": pooled.get("f1")}


def cell(run: dict) -> str:
    scores = (f"P {run['precision']:.2f} F1 {run['f1']:.2f}" if run["precision"] is not None
              else "no pruning")
    return f"{run['share']:.0%} ({run['fixed']}/{run['wrong']}), {run['models']} model(s), {scores}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--layouts", default="murals,office,twins,orbit,tiny")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--factors", default="0.7,1.5")
    parser.add_argument("--work", type=Path, default=None,
                        help="keeps each layout's first reconstruction for later runs")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    set_colmap_verbosity(False)
    layouts = args.layouts.split(",")
    factors = [float(f) for f in args.factors.split(",")]
    defaults = Tolerances().to_dict()
    settings = [("defaults", {})] + [(f"{name} x{factor:g}", {name: defaults[name] * factor})
                                     for name in NAMES for factor in factors]
    with tempfile.TemporaryDirectory(prefix="guided-sfm-sensitivity-") as tmp:
        work = args.work or Path(tmp)  # (an empty temp dir is left unused with --work)
        rows, start = [], time.perf_counter()
        for label, overrides in settings:
            row = {"setting": label, "runs": {}}
            for layout in layouts:
                row["runs"][layout] = one_run(layout, work, args.rounds, overrides)
                print(f"[{time.perf_counter() - start:6.0f} s] {label:28} {layout:7} "
                      f"{cell(row['runs'][layout])}", file=sys.stderr, flush=True)
            rows.append(row)
    if args.json:
        print(json.dumps(rows, indent=1))
        return
    print("| setting | " + " | ".join(layouts) + " |")
    print("|---|" + "---|" * len(layouts))
    for row in rows:
        print(f"| {row['setting']} | " + " | ".join(cell(row["runs"][lay]) for lay in layouts) + " |")
    short = [(row["setting"], lay) for row in rows for lay in layouts
             if row["runs"][lay]["share"] < TARGET_FIXED or row["runs"][lay]["models"] != 1]
    print(f"\n>= {TARGET_FIXED:.0%} fixed in one model everywhere: "
          + ("PASS" if not short else "FAIL: " + ", ".join(f"{s} on {lay}" for s, lay in short)))


if __name__ == "__main__":
    main()
