"""The paper's loop headless: render, reconstruct, let a simulated user place the wrong cameras,
prune, map again, and measure each round against the ground truth."""

from __future__ import annotations

import tempfile
from dataclasses import dataclass
from pathlib import Path

from guided_sfm import sample
from guided_sfm.core import checked_round, evaluation, metrics, simulated_user
from guided_sfm.core.edits import parse_edits
from guided_sfm.core.sfm import RunContext, SfmOptions
from guided_sfm.core.stage_clock import StageClock
from guided_sfm.core.triage.of_workspace import triage_workspace
from guided_sfm.core.truth import load_truth
from guided_sfm.core.types import DEFAULT_RULE, Progress, no_progress
from guided_sfm.core.workspace import Workspace


@dataclass(frozen=True)
class _Loop:
    """What every round of one demo shares."""

    out_dir: Path
    truth_file: Path
    rule: str
    tolerances: dict[str, float]
    user: str
    seed: int
    run: RunContext
    clock: StageClock
    cold: bool


def run_demo(layout: str = sample.DEFAULT_LAYOUT, seed: int = 0, rounds: int = 1,
             rule: str = DEFAULT_RULE, out_dir: Path | None = None,
             options: SfmOptions = SfmOptions(), progress: Progress = no_progress,
             cold: bool = False, tolerances: dict[str, float] | None = None,
             reuse: bool = False, user: str = "wrong") -> dict:
    """Run the loop; returns {layout, rule, rounds: [per-round report], summary}. With reuse, an
    out_dir holding the sample and its first reconstruction (round0) starts from them, so rules
    and tolerances compare on one reconstruction; user: who the simulated user places (USERS)."""
    if out_dir is None:
        with tempfile.TemporaryDirectory(prefix="guided-sfm-demo-") as tmp:
            return run_demo(layout, seed, rounds, rule, Path(tmp), options, progress, cold,
                            tolerances, user=user)
    clock = StageClock(progress)
    loop = _Loop(out_dir, out_dir / "sample" / "truth.json", rule, dict(tolerances or {}), user,
                 seed, RunContext(options, clock), clock, cold)
    base = Workspace(out_dir / "round0")
    if not (reuse and loop.truth_file.is_file() and base.sparse.is_dir()):
        with clock.timed("render"):
            sample.write_sample(out_dir / "sample", layout, seed)
        base.reconstruct(out_dir / "sample" / "images", loop.run)
    truth = load_truth(loop.truth_file)
    reports = [{"round": 0, **evaluation.evaluate_workspace(base, loop.truth_file),
                "seconds": clock.take()}]
    # status says who the simulated user moves; the round's report must judge "wrong before"
    # on the same alignment, so it is given the reference that status was aligned on.
    reference, status = None, evaluation.camera_status(base, truth)
    for number in range(1, rounds + 1):
        targets = [n for n in status.wrong + status.unregistered if n in truth.cameras]
        if not targets:
            break
        report, base = _round(loop, number, base, truth, targets, status, reference)
        reports.append({**report, "split": report["num_models"] > reports[-1]["num_models"],
                        "seconds": clock.take()})
        # "Right" keeps one meaning across rounds: align on what was right before this round.
        reference = status.right
        status = evaluation.camera_status(base, truth, reference=reference)
    return {"layout": layout, "rule": rule, "seed": seed, "user": user,
            "tolerances": loop.tolerances, **Workspace(out_dir / "round0").used(),
            "rounds": reports, "summary": _summary(reports, status)}


def _round(loop: _Loop, number: int, base: Workspace, truth, targets: list[str],
           status: evaluation.CameraStatus, reference: list[str] | None) -> tuple[dict, Workspace]:
    """One round: the simulated user places, the rule prunes, the checked re-map maps again."""
    placements, actions = _place(loop.user, base, truth, targets, status, loop.seed + number)
    edits = parse_edits({"cameras": [vars(c) for c in placements], "rule": loop.rule,
                         "tolerances": dict(loop.tolerances)}, base.image_ids())
    new = Workspace(loop.out_dir / f"round{number}")
    with loop.clock.timed("prune"):
        outcome = base.prune(edits, new)
    mapped, checked = checked_round.map_checked(new, edits, loop.run, cold=loop.cold)
    report = evaluation.evaluate_workspace(new, loop.truth_file, reference_from=base,
                                           before_reference=reference)
    return {"round": number, **report, **_round_facts(edits, outcome, mapped),
            "checked_pairs": len(checked), "actions": actions}, new


def _round_facts(edits, outcome, mapped) -> dict:
    """What a round did, beside its evaluation: moved cameras, match graph, how it mapped."""
    return {"num_moved": len(edits.cameras), "components_before": outcome.components_before,
            "components_after": outcome.components_after, "map_mode": mapped.mode,
            "map_fallback": mapped.fallback}


# The simulated users: "wrong" places each wrong or unregistered camera near its true pose;
# "all" is a capture-shape user who re-lays every camera of an orbit on one circle in capture
# order (simulated_user.place_on_circle), the right ones included; "proposals" accepts every
# run triage proposes (core/triage) and does nothing else: it never looks at the truth; "group"
# drags each split-off model as one piece onto its true place (simulated_user.move_groups) and
# places the wrong cameras of the largest model as "wrong" does.
USERS = ("wrong", "all", "proposals", "group")


def _place(user: str, base: Workspace, truth, targets: list[str],
           status: evaluation.CameraStatus, seed: int) -> tuple[list, dict[str, int]]:
    """(placements, the user's actions: drags, key presses and accepts)."""
    scene = base.scene()
    if user == "proposals":
        runs = [r for r in triage_workspace(base).runs if r.proposal]
        return [c for r in runs for c in r.proposal], simulated_user.accepts(len(runs))
    if user == "group":
        moved, actions = simulated_user.move_groups(scene, truth, status.truth_from_model)
        wrong = [n for n in targets if n in status.wrong]
        placed = simulated_user.place_cameras(scene, truth, wrong, status.truth_from_model, seed)
        by_hand = simulated_user.hand_actions(scene, placed)
        return moved + placed, {k: actions[k] + by_hand[k] for k in actions}
    if user == "all":
        everyone = [c.name for c in scene.cameras if c.name in truth.cameras]
        placed = simulated_user.place_on_circle(scene, truth, everyone, status.truth_from_model,
                                                seed)
    else:
        placed = simulated_user.place_cameras(scene, truth, targets, status.truth_from_model, seed)
    return placed, simulated_user.hand_actions(scene, placed)


def _summary(reports: list[dict], final: evaluation.CameraStatus) -> dict:
    """Wrong cameras of the first reconstruction, how many of them the loop fixed, and their
    rotation error at the end (a round's report covers only the cameras moved in it)."""
    wrong0 = set(reports[0]["wrong"]) | set(reports[0]["unregistered"])
    last = reports[-1]
    still = (set(last["wrong"]) | set(last["unregistered"])) & wrong0
    return {"initially_wrong": len(reports[0]["wrong"]),
            "initially_unregistered": len(reports[0]["unregistered"]),
            "num_images": reports[0]["num_images"],
            "fixed": len(wrong0 - still), "remaining": len(still),
            "final_wrong": last["num_wrong"], "final_models": last["num_models"],
            "final_rotation_mae_deg": evaluation.target_errors(final, sorted(wrong0))[
                "rotation_mae_deg"],
            **actions_per_fixed(reports, len(wrong0 - still)),
            "pruning_pooled": pooled_pruning(reports)}


def actions_per_fixed(reports: list[dict], fixed: int) -> dict:
    """The simulated user's actions over every round, and per camera the loop fixed."""
    totals = {"drags": 0, "key_presses": 0, "accepts": 0}
    for report in reports[1:]:
        for key in totals:
            totals[key] += report.get("actions", {}).get(key, 0)
    total = sum(totals.values())
    return {**totals, "actions_per_fixed": round(total / fixed, 2) if fixed else None}


def pooled_pruning(reports: list[dict]) -> dict | None:
    """Pruning over all rounds: precision of every deleted pair; recall against the false pairs
    of the first reconstruction's database (each later round starts from what is left of them)."""
    rounds = [r["pruning"] for r in reports[1:] if r.get("pruning")]
    if not rounds:
        return None
    deleted = sum(r["deleted"] for r in rounds)
    hits = sum(r["true_deleted"] for r in rounds)
    precision, recall, f1 = metrics.scores_from_counts(hits, deleted, rounds[0]["false_pairs"])
    return {"deleted": deleted, "true_deleted": hits, "false_pairs": rounds[0]["false_pairs"],
            "precision": precision, "recall": recall, "f1": f1}


ROUND_COLUMNS = [("round", "round"), ("registered", "num_registered"), ("wrong", "num_wrong"),
                 ("unreg.", "num_unregistered"), ("models", "num_models"),
                 ("moved", "num_moved"), ("fixed", "num_fixed"),
                 ("rot MAE", "rotation_mae_deg"), ("trans MSE", "translation_mse"),
                 ("re-map", "map_mode")]


def _cell(value: object) -> str:
    if value is None:
        return "-"
    return f"{value:.3f}" if isinstance(value, float) else str(value)


def print_report(result: dict) -> None:
    """A per-round table, pruning scores and stage times on stdout."""
    print(f"layout {result['layout']}, rule {result['rule']}, seed {result['seed']}, "
          f"matcher {result.get('matcher', '-')}, mapper {result.get('mapper', '-')}")
    print("  ".join(f"{title:>9}" for title, _ in ROUND_COLUMNS)
          + "  pruning P/R/F1   seconds per stage")
    for report in result["rounds"]:
        cells = [f"{_cell(report.get(key)):>9}" for _, key in ROUND_COLUMNS]
        pruning = report.get("pruning")
        scores = (f"{pruning['precision']:.2f}/{pruning['recall']:.2f}/{pruning['f1']:.2f}"
                  if pruning else "-")
        times = " ".join(f"{k} {v}" for k, v in report["seconds"].items())
        print("  ".join(cells) + f"  {scores:>14}   {times}")
    summary = dict(result["summary"])
    pooled = summary.pop("pruning_pooled", None)
    print("summary: " + ", ".join(f"{k} {_cell(v)}" for k, v in summary.items()))
    if pooled:
        print(f"pruning over all rounds: P {pooled['precision']:.2f}, R {pooled['recall']:.2f}, "
              f"F1 {pooled['f1']:.2f} ({pooled['true_deleted']} of {pooled['deleted']} deleted "
              f"pairs false; {pooled['false_pairs']} false pairs at the start)")
