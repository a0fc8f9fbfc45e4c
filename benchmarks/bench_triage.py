"""Triage's acceptance figures (issue 21): per layout, suspects raised at score >= 0.5 against
the truly wrong cameras (recall, precision), what accepting every proposal and nothing else fixes
in one round (and in how many models), actions per fixed camera of the proposals-only user
against the per-camera user, and the highest score on captures COLMAP gets right.

Run: .venv/bin/python benchmarks/bench_triage.py --work DIR [--layouts tiny:0 twins:0 ...]
     [--users proposals wrong] [--right tiny:1] [--real PATH_TO_WORKSPACE ...] [--json]
A layout's first reconstruction is made once under DIR/<layout>-<seed>/ and reused.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from guided_sfm import demo
from guided_sfm.core import evaluation
from guided_sfm.core.errors import DomainError
from guided_sfm.core.triage.of_workspace import triage_workspace
from guided_sfm.core.triage.suspects import RAISE_SCORE
from guided_sfm.core.truth import load_truth
from guided_sfm.core.workspace import Workspace

LAYOUTS = ["tiny:0", "twins:0", "orbit:0", "office:0", "murals:0", "split:0"]


def first_reconstruction(work: Path, layout: str, seed: int) -> Path:
    """DIR/<layout>-<seed> holding sample/ and round0/ (made on first use)."""
    out = work / f"{layout}-{seed}"
    if not (out / "round0" / "sparse").is_dir():
        demo.run_demo(layout, seed, rounds=0, out_dir=out)
    return out


def detection(out: Path) -> dict:
    """Suspects raised against the cameras wrong (or unregistered) in the first reconstruction."""
    base = Workspace(out / "round0")
    status = evaluation.camera_status(base, load_truth(out / "sample" / "truth.json"))
    wrong = set(status.wrong) | set(status.unregistered)
    start = time.perf_counter()
    result = triage_workspace(base)
    seconds = time.perf_counter() - start
    names = base.image_names()
    raised = {names[s.image_id] for s in result.suspects if s.score >= RAISE_SCORE}
    # images outside the largest model appear only in runs (design.md v1.1): count them there
    raised |= {names[i] for r in result.runs for i in r.image_ids if names[i] in status.unregistered}
    hits = len(raised & wrong)
    return {"wrong": len(wrong), "raised": len(raised), "hits": hits,
            "recall": hits / len(wrong) if wrong else None,
            "precision": hits / len(raised) if raised else None,
            "max_score": max((s.score for s in result.suspects), default=0.0),
            "runs": len(result.runs), "models": len(base.load_models()),
            "triage_seconds": round(seconds, 2)}


def one_round(out: Path, layout: str, seed: int, user: str) -> dict:
    """One round of `demo` by this simulated user from the shared first reconstruction."""
    own = out / "users" / user
    own.mkdir(parents=True, exist_ok=True)
    for name in ("sample", "round0"):
        if not (own / name).exists():
            (own / name).symlink_to(out / name)
    try:
        result = demo.run_demo(layout, seed, rounds=1, out_dir=own, reuse=True, user=user)
    except DomainError as exc:  # e.g. a round that leaves too few cameras to align with truth
        return {"error": str(exc)}
    summary = result["summary"]
    wrong = summary["initially_wrong"] + summary["initially_unregistered"]
    return {"fixed": summary["fixed"], "of": wrong,
            "fixed_share": summary["fixed"] / wrong if wrong else None,
            "models": summary["final_models"], "final_wrong": summary["final_wrong"],
            "drags": summary["drags"], "key_presses": summary["key_presses"],
            "accepts": summary["accepts"], "actions_per_fixed": summary["actions_per_fixed"]}


def no_false_alarms(workspace: Path) -> dict:
    """On a capture COLMAP gets right: how many suspects reach the raise score, and the highest."""
    result = triage_workspace(Workspace(workspace))
    scores = [s.score for s in result.suspects]
    return {"cameras": len(scores), "raised": sum(s >= RAISE_SCORE for s in scores),
            "max_score": max(scores, default=0.0), "runs": len(result.runs)}


def _spec(text: str) -> tuple[str, int]:
    layout, _, seed = text.partition(":")
    return layout, int(seed or 0)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", required=True, type=Path)
    parser.add_argument("--layouts", nargs="*", default=LAYOUTS)
    parser.add_argument("--users", nargs="*", default=["proposals", "wrong"])
    parser.add_argument("--right", nargs="*", default=["tiny:1"],
                        help="renderings COLMAP gets right (no suspect may reach 0.5)")
    parser.add_argument("--real", nargs="*", default=[], type=Path,
                        help="workspaces of real photographs COLMAP gets right (e.g. Lund)")
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    report: dict = {"layouts": {}, "right": {}}
    for text in args.layouts:
        layout, seed = _spec(text)
        out = first_reconstruction(args.work, layout, seed)
        row = {"detection": detection(out)}
        for user in args.users:
            row[user] = one_round(out, layout, seed, user)
        report["layouts"][text] = row
        print(f"{text}: {json.dumps(row)}", file=sys.stderr)
    for text in args.right:
        report["right"][text] = no_false_alarms(first_reconstruction(args.work, *_spec(text)) / "round0")
    for path in args.real:
        report["right"][path.name] = no_false_alarms(path)
    print(json.dumps(report) if args.json else _table(report))
    return 0


def _table(report: dict) -> str:
    """Detection per layout, then one line per simulated user's round."""
    lines = ["layout     wrong raised recall precision runs triage_s   user: fixed models "
             "drags keys accepts act/fixed"]
    for name, row in report["layouts"].items():
        d = row["detection"]
        lines.append(f"{name:<10} {d['wrong']:>5} {d['raised']:>6} {_f(d['recall']):>6} "
                     f"{_f(d['precision']):>9} {d['runs']:>4} {d['triage_seconds']:>8}")
        for user, r in row.items():
            if user == "detection":
                continue
            if "error" in r:
                lines.append(f"{'':>52}{user}: {r['error']}")
                continue
            lines.append(f"{'':>52}{user}: {r['fixed']}/{r['of']} {r['models']} {r['drags']} "
                         f"{r['key_presses']} {r['accepts']} {_f(r['actions_per_fixed'])}")
    for name, row in report["right"].items():
        lines.append(f"right: {name}: {row['raised']} of {row['cameras']} raised, "
                     f"max score {row['max_score']:.2f}, {row['runs']} runs")
    return "\n".join(lines)


def _f(value) -> str:
    return "-" if value is None else f"{value:.2f}"


if __name__ == "__main__":
    sys.exit(main())
