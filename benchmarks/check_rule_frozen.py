"""Freeze the rules' inputs and outputs, then check that a change of code leaves them byte-identical.

Inputs: bench_rule's synthetic walk (300 cameras, seed 0; scene, edit set, pairs and evidence
saved as JSON and npz, so a change to the generator cannot move them) and copies of reconstructed
sample workspaces, each with edit sets made once from its truth (the simulated user's placement
of the wrong cameras, a few cameras swapped onto each other's poses, manual deletions, changed
tolerances). Outputs: per case and rule, the sorted deleted pairs with the tests that removed
each, the pairs kept to connect and the component counts, as canonical JSON.

Run: .venv/bin/python benchmarks/check_rule_frozen.py --save DIR [--workspace WS TRUTH]...
     .venv/bin/python benchmarks/check_rule_frozen.py --compare DIR
(--save refuses a DIR that exists; --compare exits 1 on the first case that differs.)
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
from pathlib import Path

import numpy as np

from guided_sfm.core import evaluation, simulated_user
from guided_sfm.core.edits import edits_to_json, parse_edits
from guided_sfm.core.rule.driver import prune_pairs
from guided_sfm.core.rule.evidence import Evidence
from guided_sfm.core.truth import load_truth
from guided_sfm.core.types import TopDownScene
from guided_sfm.core.workspace import Workspace

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_rule import synthetic_capture  # noqa: E402

RULES = ("default", "paper")
SWAPPED = 3  # cameras each put on another camera's pose
# A scene is rebuilt from the models, not read: its floats may move in the last bits when a formula
# is written another way (a camera centre as one einsum rather than R^T t).
SCENE_TOLERANCE = 1e-9


def _dump(value) -> str:
    return json.dumps(value, sort_keys=True, indent=1) + "\n"


def _record(result, names: dict[int, str], before: int | None = None,
            after: int | None = None) -> dict:
    """A rule's result with pairs by name: [name1, name2, tests] sorted, kept pairs sorted."""
    def named(pair):
        return sorted((names[pair[0]], names[pair[1]]))

    record = {"deleted": sorted([*named(p), list(result.reasons[p])] for p in result.deleted),
              "kept_to_connect": sorted(named(p) for p in result.kept_to_connect)}
    if before is not None:
        record |= {"components_before": before, "components_after": after}
    return record


# -- the synthetic walk --------------------------------------------------------------------------

def save_evidence(evidence: Evidence, path: Path) -> None:
    keys = sorted(evidence.matches)
    np.savez_compressed(
        path, row_ids=np.array(list(evidence.rows), dtype=np.int64),
        row_values=np.array(list(evidence.rows.values()), dtype=np.int64),
        rotations=evidence.rotations, translations=evidence.translations,
        offsets=evidence.offsets, rays=evidence.rays, points=evidence.points,
        match_keys=np.array(keys, dtype=np.int64).reshape(-1, 2),
        match_sizes=np.array([len(evidence.matches[k]) for k in keys], dtype=np.int64),
        match_rows=np.concatenate([np.zeros((0, 2), np.int64)]
                                  + [evidence.matches[k] for k in keys]).astype(np.int64))


def load_evidence(path: Path) -> Evidence:
    with np.load(path) as npz:
        data = {name: npz[name] for name in npz.files}  # an NpzFile decompresses on every access
    bounds = np.concatenate([[0], np.cumsum(data["match_sizes"])])
    rows = data["match_rows"]
    matches = {(int(a), int(b)): rows[bounds[i]:bounds[i + 1]]
               for i, (a, b) in enumerate(data["match_keys"])}
    return Evidence(rows=dict(zip(data["row_ids"].tolist(), data["row_values"].tolist(), strict=True)),
                    rotations=data["rotations"], translations=data["translations"],
                    offsets=data["offsets"], rays=data["rays"], points=data["points"],
                    matches=matches)


def save_synthetic(out: Path) -> None:
    scene, edits, pairs, evidence = synthetic_capture(300, 30, seed=0)
    out.mkdir(parents=True)
    (out / "scene.json").write_text(json.dumps(scene.to_dict()))
    (out / "edits.json").write_text(json.dumps(edits_to_json(edits)))
    (out / "pairs.json").write_text(json.dumps([[a, b, n] for (a, b), n in sorted(pairs.items())]))
    save_evidence(evidence, out / "evidence.npz")


def run_synthetic(folder: Path) -> dict[str, str]:
    scene = TopDownScene.from_dict(json.loads((folder / "scene.json").read_text()))
    body = json.loads((folder / "edits.json").read_text())
    pairs = {(a, b): n for a, b, n in json.loads((folder / "pairs.json").read_text())}
    evidence = load_evidence(folder / "evidence.npz")
    ids = {c.name: c.image_id for c in scene.cameras}
    names = {c.image_id: c.name for c in scene.cameras}
    out = {}
    for rule in RULES:
        edits = parse_edits({**body, "rule": rule}, ids)
        out[f"synthetic/{rule}"] = _dump(_record(prune_pairs(scene, edits, pairs, evidence), names))
    return out


# -- sample workspaces ---------------------------------------------------------------------------

def edit_bodies(ws: Path, truth_file: Path) -> dict[str, dict]:
    """Edit sets by image name, made once from the truth (see the module's docstring)."""
    truth, workspace = load_truth(truth_file), Workspace(ws)
    status = evaluation.camera_status(workspace, truth)
    scene = workspace.scene()
    targets = [n for n in status.wrong + status.unregistered if n in truth.cameras]
    placed = simulated_user.place_cameras(scene, truth, targets, status.truth_from_model, seed=1)
    by_id = {c.image_id: c for c in scene.cameras}
    wrong = [{"name": by_id[e.image_id].name, "x": e.x, "y": e.y, "yaw_deg": e.yaw_deg}
             for e in placed]
    posed = [c for c in scene.cameras if c.x is not None]
    step = max(1, len(posed) // (SWAPPED + 1))
    chosen = posed[::step][:SWAPPED]
    swapped = [{"name": a.name, "x": b.x, "y": b.y, "yaw_deg": b.yaw_deg}
               for a, b in zip(chosen, chosen[1:] + chosen[:1], strict=True)]
    moved = {c["name"] for c in wrong + swapped}
    pairs = sorted(workspace.verified_pairs())
    unmoved = [p for p in pairs if not {by_id[p[0]].name, by_id[p[1]].name} & moved]
    manual = [[by_id[a].name, by_id[b].name] for a, b in unmoved[:: max(1, len(unmoved) // 3)][:3]]
    return {
        "wrong": {"cameras": wrong},
        "wrong+manual": {"cameras": wrong, "delete_pairs": manual},
        "swapped": {"cameras": swapped},
        "wrong+tolerances": {"cameras": wrong, "tolerances": {"placement_deg": 15.0,
                                                              "range_scale": 0.5,
                                                              "rotation_deg": 10.0}},
    }


def save_workspace(ws: Path, truth_file: Path, out: Path) -> None:
    shutil.copytree(ws, out / "workspace")
    bodies = edit_bodies(out / "workspace", truth_file)
    (out / "edit_sets.json").write_text(json.dumps(bodies, indent=1))


def run_workspace(folder: Path) -> dict[str, str]:
    ws = Workspace(folder / "workspace")
    ids = ws.image_ids()
    names = {i: n for n, i in ids.items()}
    out = {}
    for case, body in json.loads((folder / "edit_sets.json").read_text()).items():
        for rule in RULES:
            outcome = ws.preview(parse_edits({**body, "rule": rule}, ids))
            record = _record(outcome, names, outcome.components_before, outcome.components_after)
            out[f"{folder.name}/{case}/{rule}"] = _dump(record)
    out[f"{folder.name}/scene"] = _dump(ws.build_scene().to_dict())  # rebuilt from the models
    return out


# -- save / compare ------------------------------------------------------------------------------

def run_all(root: Path) -> dict[str, str]:
    outputs = run_synthetic(root / "synthetic")
    for folder in sorted((root / "workspaces").iterdir()):
        outputs |= run_workspace(folder)
    return outputs


def save(root: Path, workspaces: list[tuple[str, str]]) -> None:
    root.mkdir(parents=True)
    save_synthetic(root / "synthetic")
    (root / "workspaces").mkdir()
    for ws, truth in workspaces:
        save_workspace(Path(ws), Path(truth), root / "workspaces" / Path(ws).name)
    outputs = run_all(root)
    (root / "outputs.json").write_text(json.dumps(outputs, indent=1, sort_keys=True))
    _summary(outputs)


def _rules(outputs: dict[str, str]) -> dict[str, dict]:
    """The rule cases' records (the rebuilt scenes left out)."""
    return {case: json.loads(text) for case, text in outputs.items() if not case.endswith("/scene")}


def _summary(outputs: dict[str, str]) -> None:
    for case, record in sorted(_rules(outputs).items()):
        print(f"{case:<40} deleted {len(record['deleted']):>5}  kept {len(record['kept_to_connect']):>3}")


def _largest_difference(a, b) -> float:
    """Largest difference between two JSON values' numbers; inf where their shapes differ."""
    if isinstance(a, dict) and isinstance(b, dict) and a.keys() == b.keys():
        return max((_largest_difference(a[k], b[k]) for k in a), default=0.0)
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        return max((_largest_difference(x, y) for x, y in zip(a, b, strict=True)), default=0.0)
    if isinstance(a, int | float) and isinstance(b, int | float):
        return abs(a - b)
    return 0.0 if a == b else float("inf")


def _same(case: str, expected: str, found: str | None) -> bool:
    """Rule outputs byte for byte; a rebuilt scene to SCENE_TOLERANCE (model units, degrees)."""
    if found is None or not case.endswith("/scene"):
        return found == expected
    difference = _largest_difference(json.loads(expected), json.loads(found))
    print(f"{case}: largest difference {difference:.1e}")
    return difference <= SCENE_TOLERANCE


def compare(root: Path) -> int:
    expected = json.loads((root / "outputs.json").read_text())
    outputs = run_all(root)
    _summary(outputs)
    differ = [case for case in sorted(expected) if not _same(case, expected[case], outputs.get(case))]
    extra = sorted(set(outputs) - set(expected))
    rules = _rules(expected)
    pairs = sum(len(record["deleted"]) for record in rules.values())
    kept = sum(len(record["kept_to_connect"]) for record in rules.values())
    print(f"{len(rules)} rule cases ({pairs} deleted pairs, {kept} kept to connect) and "
          f"{len(expected) - len(rules)} rebuilt scenes compared: {len(differ)} differ, "
          f"{len(extra)} unexpected")
    for case in differ:
        print(f"DIFFERS: {case}")
    return 1 if differ or extra else 0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument("--save", type=Path, metavar="DIR")
    group.add_argument("--compare", type=Path, metavar="DIR")
    parser.add_argument("--workspace", nargs=2, action="append", default=[],
                        metavar=("WS", "TRUTH"), help="a reconstructed sample and its truth.json")
    args = parser.parse_args()
    if args.save:
        save(args.save, args.workspace)
    else:
        sys.exit(compare(args.compare))


if __name__ == "__main__":
    main()
