"""The default rule's pruning of one demo round, prune only, against the truth's false pairs: why
the false pairs it keeps are kept (docs/pruning-rule.md, "hall-1000: why recall is 0.64").

    .venv/bin/python benchmarks/bench_prune_truth.py DEMO_DIR [--round 1] [--json]

DEMO_DIR is a `demo --out` folder (or bench_scale's `<layout>-<matcher>-round`): sample/truth.json,
round<N-1>/ (the base) and round<N>/edits.json (the simulated user's placements). The round's
edit set is previewed again on its base with the code as it is now (nothing is written), timed,
and scored; then every tested false pair the rule keeps is put in one of these bins, in order:
no evidence (a member outside the evidence: the frustum test alone judged it), relative-pose
keep (its matches agree with the model and the placements keep their relative pose, which
outranks the carried angle), under the carried-angle tolerance (the match-placement test's
0.4-quantile angle at or below placement_deg, + yaw_uncertainty_deg with both members moved).
Also by capture-order gap (names in order; the loop closes) and by where the members are.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import time
from collections import Counter
from pathlib import Path

from guided_sfm.core.edits import parse_edits
from guided_sfm.core.metrics import pruning_scores
from guided_sfm.core.rule import driver
from guided_sfm.core.rule.evidence import flat_matches
from guided_sfm.core.rule.frustum import placed_frusta
from guided_sfm.core.rule.match_placement import placement_test
from guided_sfm.core.rule.motion import motions_of
from guided_sfm.core.rule.relative_pose import relative_pose_test
from guided_sfm.core.rule.tolerances import Tolerances
from guided_sfm.core.truth import false_pairs, load_truth
from guided_sfm.core.workspace import Workspace


def _cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def kept_bins(base: Workspace, edits, pairs, evidence, false: set) -> dict[tuple, str]:
    """Per tested false pair, why the default rule's tests keep it (or "removed")."""
    tolerances = Tolerances(**edits.tolerances)
    placements = {c.image_id: c for c in edits.cameras}
    scene = base.scene()
    tested = driver.tested_pairs(pairs, placements, placed_frusta(scene, placements,
                                                                  tolerances.range_scale))
    flat = flat_matches(evidence, tested)
    motions = motions_of(scene, placements, evidence)
    placement = placement_test(flat, motions, evidence, tolerances)
    relative = relative_pose_test(flat, motions, evidence, tolerances)
    bins = {}
    for k, key in enumerate(map(tuple, tested.tolist())):
        if key not in false:
            continue
        if not placement.judged[k]:
            bins[key] = "no evidence (frustum test alone)"
        elif relative.judged[k] and not relative.removed[k]:
            bins[key] = "relative-pose keep (agrees with the model)"
        elif not placement.removed[k] and not relative.removed[k]:
            bins[key] = "carried angle under its tolerance, no relative-pose verdict"
        else:
            bins[key] = "removed by placement or relative pose"
    return bins


def report(demo: Path, number: int) -> dict:
    base = Workspace(demo / f"round{number - 1}")
    truth = load_truth(demo / "sample" / "truth.json")
    record = json.loads((demo / f"round{number}" / "edits.json").read_text())
    record.pop("frame", None)
    edits = parse_edits(record, base.image_ids())
    names = base.image_names()
    rank = {i: r for r, i in enumerate(sorted(names, key=lambda i: names[i]))}
    pairs = base.verified_pairs()
    started, cpu = time.perf_counter(), _cpu()
    evidence = base.rule_evidence(edits, pairs)
    result = driver.prune_pairs(base.scene(), edits, pairs, evidence)
    seconds, cpu = time.perf_counter() - started, _cpu() - cpu
    false = false_pairs(base.require(), truth)
    deleted = set(result.deleted)
    precision, recall, _ = pruning_scores(deleted, false)
    bins = kept_bins(base, edits, pairs, evidence, false)
    model_of = {i: index for index, model in enumerate(base.load_models())
                for i in model.reg_image_ids()}
    kept = [key for key in false if key not in deleted]

    def where(key):
        return "+".join(sorted(str(model_of.get(i, "none")) for i in key))

    def gap(key):
        step = abs(rank[key[0]] - rank[key[1]])
        step = min(step, len(names) - step)
        return str(step) if step <= 12 else ">12"

    return {
        "demo": demo.name, "round": number, "pairs": len(pairs), "false": len(false),
        "deleted": len(deleted), "false_deleted": len(deleted & false),
        "precision": round(precision, 3), "recall": round(recall, 3),
        "prune_wall_s": round(seconds, 2), "prune_cpu_s": round(cpu, 2),
        "load": os.getloadavg()[0],
        "removed_by_test": dict(Counter(t for r in result.reasons.values() for t in r)),
        "false_kept_by_reason": dict(Counter(bins.get(k, "not tested (no moved member)")
                                             for k in kept)),
        "false_kept_by_models": dict(Counter(where(k) for k in kept)),
        "false_by_models": dict(Counter(where(k) for k in false)),
        "false_kept_by_gap": dict(Counter(gap(k) for k in kept)),
        "false_by_gap": dict(Counter(gap(k) for k in false)),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("demo", type=Path)
    parser.add_argument("--round", type=int, default=1)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    out = report(args.demo, args.round)
    if args.json:
        print(json.dumps(out, indent=1))
        return
    for key, value in out.items():
        if isinstance(value, dict):
            print(f"{key}:")
            for name, count in sorted(value.items(), key=lambda item: -item[1]):
                print(f"    {name}: {count}")
        else:
            print(f"{key}: {value}")


if __name__ == "__main__":
    main()
