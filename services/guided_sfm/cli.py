"""`guided-sfm`: the command line. stdout carries results only; progress and logs go to stderr."""

from __future__ import annotations

import argparse
import json
import logging
import sys
from collections.abc import Callable, Sequence
from pathlib import Path

import PIL.Image  # noqa: F401  (before pycolmap: Pillow after it corrupts the heap on PNG save)
from tqdm import tqdm

from guided_sfm.core.errors import DomainError
from guided_sfm.core.types import DEFAULT_RULE, RULES, Progress


class ProgressBar:
    """A tqdm bar on stderr per stage, fed by progress(stage, fraction) callbacks."""

    def __init__(self, enabled: bool = True) -> None:
        self.enabled = enabled
        self.bar: tqdm | None = None
        self.stage = ""

    def __call__(self, stage: str, fraction: float) -> None:
        if not self.enabled:
            return
        if stage != self.stage:
            self.close()
            self.stage = stage
            self.bar = tqdm(total=1000, desc=stage, file=sys.stderr, leave=False,
                            bar_format="{desc:>10} {percentage:3.0f}%|{bar}| {elapsed}")
        self.bar.n = round(1000 * min(max(fraction, 0.0), 1.0))
        self.bar.refresh()

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def print_json(data: object) -> None:
    print(json.dumps(data, indent=None, sort_keys=True))


def print_table(rows: Sequence[tuple[str, object]]) -> None:
    width = max(len(key) for key, _ in rows)
    for key, value in rows:
        print(f"{key:<{width}}  {value}")


def cmd_sample(args: argparse.Namespace) -> None:
    from guided_sfm import sample

    if args.layout == "list":
        print("\n".join(sorted(sample.LAYOUTS)))
        return
    with ProgressBar() as bar:
        out = sample.write_sample(Path(args.out_dir), args.layout, args.seed, bar)
    print(out)


def _options(args: argparse.Namespace):
    from guided_sfm.core.sfm import SfmOptions

    extra = {"num_threads": args.threads} if getattr(args, "threads", None) else {}
    if getattr(args, "placement_prior", None) is not None:
        extra["placement_prior"] = args.placement_prior
    if getattr(args, "max_image_size", None) is not None:
        extra["max_image_size"] = args.max_image_size or None
    return SfmOptions(matcher=getattr(args, "matcher", "auto"),
                      mapper=getattr(args, "mapper", "incremental"),
                      features=getattr(args, "features", "standard"), **extra)


def cmd_reconstruct(args: argparse.Namespace) -> None:
    from guided_sfm.core.sfm import RunContext
    from guided_sfm.core.stage_clock import StageClock, format_report
    from guided_sfm.core.workspace import Workspace

    workspace = Workspace(args.workspace)
    with ProgressBar() as bar:
        clock = StageClock(bar)
        workspace.reconstruct(Path(args.images_dir), RunContext(_options(args), clock))
    used = workspace.used()
    matcher = used["matcher"] if args.matcher == used["matcher"] else f"{args.matcher}: {used['matcher']}"
    print_table([*sorted(workspace.stats().items()), ("matcher", matcher), ("mapper", used["mapper"]),
                 ("max_image_size", used["max_image_size"]), *format_report(clock.report())])


def cmd_scene(args: argparse.Namespace) -> None:
    from guided_sfm.core.workspace import Workspace

    scene = Workspace(args.workspace).scene()
    if args.png:
        from guided_sfm import plot

        plot.plot_scene(scene, Path(args.png))
    if args.json or not args.png:
        print_json(scene.to_dict())


def cmd_suspects(args: argparse.Namespace) -> None:
    from guided_sfm.core.triage.of_workspace import triage_workspace
    from guided_sfm.core.triage.suspects import RAISE_SCORE
    from guided_sfm.core.workspace import Workspace

    workspace = Workspace(args.workspace)
    document = triage_workspace(workspace).to_dict(workspace.image_names())
    if not args.json:  # a readable summary first; the last line is the document either way
        raised = [s for s in document["suspects"] if s["score"] >= RAISE_SCORE]
        print_table([("suspects", f"{len(raised)} at score >= {RAISE_SCORE}"),
                     *((s["name"], f"{s['score']:.2f}  {s['reasons'][0] if s['reasons'] else ''}")
                       for s in raised),
                     ("runs", len(document["runs"])),
                     *((r["names"][0], r["reason"]) for r in document["runs"])])
    print_json(document)


def read_json(path: str) -> object:
    try:
        return json.loads(Path(path).read_text())
    except FileNotFoundError as exc:
        raise DomainError(f"no such file: {path}") from exc
    except ValueError as exc:
        raise DomainError(f"{path} is not valid JSON: {exc}") from exc


def cmd_prune(args: argparse.Namespace) -> None:
    from guided_sfm.core.edits import parse_edits
    from guided_sfm.core.workspace import Workspace, pruning_record

    base = Workspace(args.workspace)
    edits = parse_edits(read_json(args.edits), base.image_ids())
    outcome = base.preview(edits) if args.dry_run else base.prune(edits, Workspace(args.new_workspace))
    record = pruning_record(outcome, base.image_names())
    if args.json:
        print_json(record)
    else:
        print_table([("deleted pairs", len(record["deleted_pairs"])),
                     ("components before", record["components_before"]),
                     ("components after", record["components_after"]),
                     ("removed by test", record["removed_by_test"]),
                     ("kept to connect", len(record["kept_to_connect"]))])


def cmd_map(args: argparse.Namespace) -> None:
    from guided_sfm.core.sfm import RunContext
    from guided_sfm.core.stage_clock import StageClock, format_report
    from guided_sfm.core.workspace import Workspace

    workspace = Workspace(args.workspace)
    with ProgressBar() as bar:
        clock = StageClock(bar)
        report = workspace.map_again(RunContext(_options(args), clock), cold=args.cold)
    print_table([("mode", report.mode), ("fallback", report.fallback or "-"),
                 ("seconds", report.seconds), *sorted(workspace.stats().items()),
                 *format_report(clock.report())])


def cmd_evaluate(args: argparse.Namespace) -> None:
    from guided_sfm.core import evaluation
    from guided_sfm.core.workspace import Workspace

    reference = Workspace(args.reference_from) if args.reference_from else None
    report = evaluation.evaluate_workspace(Workspace(args.workspace), Path(args.truth), reference)
    if args.json:
        print_json(report)
    else:
        print_table([(k, v) for k, v in report.items() if not isinstance(v, list | dict)])


def _tolerances(items: Sequence[str] | None) -> dict[str, float]:
    """NAME=VALUE pairs (the edit set's tolerances) as a dict; the core validates the names."""
    out = {}
    for item in items or []:
        name, _, value = item.partition("=")
        try:
            out[name.strip()] = float(value)
        except ValueError as exc:
            raise DomainError(f"--tolerance {item!r}: expected NAME=NUMBER") from exc
    return out


def cmd_demo(args: argparse.Namespace) -> None:
    from guided_sfm import demo

    with ProgressBar() as bar:
        result = demo.run_demo(layout=args.layout, seed=args.seed, rounds=args.rounds,
                               rule=args.rule, out_dir=Path(args.out) if args.out else None,
                               options=_options(args), progress=bar, cold=args.cold,
                               tolerances=_tolerances(args.tolerance), reuse=args.reuse,
                               user=args.user)
    if args.json:
        print_json(result)
    else:
        demo.print_report(result)


# The engine's options, shared by reconstruct (all), map (mapper, threads) and demo (matcher).
SFM_ARGS = [("--matcher", {"choices": ["auto", "exhaustive", "sequential", "retrieval"],
                           "default": "auto",
                           "help": "auto: exhaustive up to a number of images, retrieval above "
                                   "it (docs/engine.md)"}),
            ("--mapper", {"choices": ["incremental", "global", "hierarchical"],
                          "default": "incremental"}),
            ("--threads", {"type": int, "default": None}),
            ("--features", {"choices": ["standard", "colmap"], "default": "standard",
                            "help": "colmap: COLMAP's own SIFT octaves and threshold, about "
                                    "2x slower (see docs/engine.md)"}),
            ("--placement-prior", {"action": argparse.BooleanOptionalAction, "default": None,
                                   "help": "hold the re-map to the round's placements "
                                           "(position priors; docs/pruning-rule.md)"}),
            ("--max-image-size", {"type": int, "default": None, "metavar": "PIXELS",
                                  "help": "SIFT's longest side: larger photos are extracted "
                                          "scaled down (default 1600; 0: COLMAP's own, 3200)"})]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="guided-sfm", description=__doc__)
    parser.add_argument("-v", "--verbose", action="store_true", help="show COLMAP's own log")
    sub = parser.add_subparsers(dest="command", required=True)
    _add(sub, "sample", cmd_sample, "render a sample scene with ground truth",
         [("out_dir",), ("--layout", {"default": None}), ("--seed", {"type": int, "default": 0})])
    _add(sub, "reconstruct", cmd_reconstruct, "images -> COLMAP workspace",
         [("images_dir",), ("workspace",), *SFM_ARGS])
    _add(sub, "scene", cmd_scene, "the top-down scene of a workspace",
         [("workspace",), ("--json", {"action": "store_true"}), ("--png", {"default": None})])
    _add(sub, "suspects", cmd_suspects, "cameras likely misplaced, with runs and proposals",
         [("workspace",), ("--json", {"action": "store_true"})])
    _add(sub, "prune", cmd_prune, "delete the pairs an edit set rules out into a new workspace",
         [("workspace",), ("edits",), ("new_workspace",),
          ("--dry-run", {"action": "store_true"}), ("--json", {"action": "store_true"})])
    _add(sub, "map", cmd_map, "map a workspace's database again",
         [("workspace",), ("--cold", {"action": "store_true"}), *SFM_ARGS[1:3], SFM_ARGS[4]])
    _add(sub, "evaluate", cmd_evaluate, "the paper's metrics against ground truth",
         [("workspace",), ("--truth", {"required": True}), ("--reference-from", {"default": None}),
          ("--json", {"action": "store_true"})])
    _add(sub, "demo", cmd_demo, "the paper's loop headless on a freshly rendered sample",
         [("--layout", {"default": None}), ("--seed", {"type": int, "default": 0}),
          ("--rounds", {"type": int, "default": 1}), ("--rule", {"default": DEFAULT_RULE,
                                                               "choices": list(RULES)}),
          ("--out", {"default": None}), ("--cold", {"action": "store_true"}), SFM_ARGS[0],
          SFM_ARGS[4],
          ("--tolerance", {"action": "append", "metavar": "NAME=VALUE",
                           "help": "override one of the default rule's tolerances"}),
          ("--reuse", {"action": "store_true",
                       "help": "start from --out's existing sample and round0 if present"}),
          ("--user", {"default": "wrong", "choices": ["wrong", "all", "proposals", "group"],
                      "help": "wrong: place the wrong cameras near their truth; all: re-lay every "
                              "camera of an orbit on a circle in capture order; proposals: accept "
                              "every run `suspects` proposes, nothing else; group: drag each "
                              "split-off model into place as one piece"}),
          ("--json", {"action": "store_true"})])
    _register_service(sub)
    return parser


def _add(sub, name: str, func: Callable, help_: str, arguments: list[tuple]) -> None:
    command = sub.add_parser(name, help=help_, description=help_)
    for spec in arguments:
        command.add_argument(spec[0], **(spec[1] if len(spec) > 1 else {}))
    command.set_defaults(func=func)


def _register_service(sub) -> None:
    from guided_sfm import remote_cli, service_cli

    service_cli.register(sub)
    remote_cli.register(sub)


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    logging.basicConfig(level=logging.INFO if args.verbose else logging.WARNING,
                        stream=sys.stderr, format="%(levelname)s %(name)s: %(message)s")
    from guided_sfm.core import sfm

    sfm.set_colmap_verbosity(args.verbose)
    if getattr(args, "layout", "") is None:
        from guided_sfm.sample import DEFAULT_LAYOUT

        args.layout = DEFAULT_LAYOUT
    try:
        args.func(args)
    except DomainError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
