"""`suspects` at editor scale (issue 21: 300 cameras in <= 2 s): triage of a synthetic walked-hall
workspace (benchmarks/synthetic_workspace.py: pycolmap, no pixels, 200 model points per camera)
at each size, cold (a fresh process that has read nothing of it yet) and cached (again in the
same process), median of the repeats, with the load average before and after (2 shared cores:
read the wall-clock figures against it; the cold run's CPU seconds are steadier) and the seconds
of each stage in one cold run.

    .venv/bin/python benchmarks/bench_suspects.py --work DIR [--cameras 300 1000] [--repeats 3]
        [--api] [--json]
A size's workspace is written once under DIR/hall-<cameras>/ and reused. With --api, the
workspace is also imported into a `guided-sfm serve` of its own (bench_editor_api.py) and
GET .../versions/{vid}/suspects is timed: the first request after each server start (the server
computes and caches the answer), then once more (cached).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from synthetic_workspace import write_workspace  # noqa: E402

POINTS_PER_CAMERA = 200  # synthetic_workspace's default: 200,000 points for 1,000 cameras


def workspace_of(work: Path, cameras: int) -> Path:
    root = work / f"hall-{cameras}"
    if not (root / "scene.json").is_file():
        write_workspace(root, cameras, POINTS_PER_CAMERA * cameras)
    return root


def timed_runs(root: Path, runs: int) -> dict:
    """In this process: the seconds of each triage of the workspace (the first one cold), the
    stages of the first, and what it raised."""
    from guided_sfm.core.triage import evidence, of_workspace, suspects, two_view
    from guided_sfm.core.triage.of_workspace import triage_workspace
    from guided_sfm.core.workspace import Workspace

    stages: dict[str, float] = {}

    def clocked(name, function):
        def wrapper(*args, **kwargs):
            start = time.perf_counter()
            try:
                return function(*args, **kwargs)
            finally:
                stages[name] = stages.get(name, 0.0) + time.perf_counter() - start
        return wrapper

    # the stages of triage_workspace, clocked where of_workspace looks them up
    evidence.read_model = clocked("evidence", evidence.read_model)  # the model's files, read once
    evidence.gather = clocked("evidence", evidence.gather)
    two_view.anchors_of = clocked("two_view", two_view.anchors_of)
    of_workspace.triage = clocked("judge", suspects.triage)
    seconds, cpu, result = [], [], None
    for index in range(runs):
        start, start_cpu = time.perf_counter(), time.process_time()
        result = triage_workspace(Workspace(root))
        seconds.append(time.perf_counter() - start)
        cpu.append(time.process_time() - start_cpu)
        if index == 0:
            first = dict(stages)
    return {"seconds": seconds, "cpu": cpu, "stages": {k: round(v, 3) for k, v in first.items()},
            "cameras": len(result.suspects), "raised": sum(s.score >= suspects.RAISE_SCORE
                                                            for s in result.suspects),
            "runs": len(result.runs)}


def cold_and_cached(root: Path, repeats: int) -> dict:
    """Cold: the first triage in each of `repeats` fresh processes; cached: the later triages
    of one process. Medians, and every figure."""
    colds, cached, cpu, last = [], [], [], None
    for _ in range(repeats):
        out = subprocess.run([sys.executable, __file__, "--one", str(root), "--runs",
                              str(repeats + 1)], capture_output=True, text=True, check=True)
        last = json.loads(out.stdout.strip().splitlines()[-1])
        colds.append(last["seconds"][0])
        cached.extend(last["seconds"][1:])
        cpu.append(last["cpu"][0])
    return {"cold_s": round(statistics.median(colds), 3), "cached_s": round(statistics.median(cached), 3),
            "cold_cpu_s": round(statistics.median(cpu), 3),
            "cold_all": [round(s, 3) for s in colds], "cached_all": [round(s, 3) for s in cached],
            "stages_cold": last["stages"], "suspects": last["cameras"], "raised": last["raised"],
            "runs": last["runs"]}


def route_times(root: Path, repeats: int) -> dict:
    """Seconds of GET .../suspects: the first request after each of `repeats` server starts,
    and the request after it (the server's version cache)."""
    import signal
    import tempfile

    import httpx
    from bench_editor_api import imported, serve

    cold, cached = [], []
    with tempfile.TemporaryDirectory(prefix="bench-suspects-") as tmp:
        data, port = Path(tmp) / "data", 20000 + os.getpid() % 20000
        data.mkdir()
        url, token, pid, vid = f"http://127.0.0.1:{port}", None, None, None
        for _ in range(repeats):
            server = serve(data, port)
            try:
                if token is None:
                    token, pid, vid = imported(url, root)
                route = f"{url}/api/v1/projects/{pid}/versions/{vid}/suspects"
                for times in (cold, cached):
                    start = time.perf_counter()
                    response = httpx.get(route, headers={"Authorization": f"Bearer {token}"},
                                         timeout=600)
                    response.raise_for_status()
                    times.append(time.perf_counter() - start)
            finally:
                server.send_signal(signal.SIGTERM)
                server.wait(timeout=60)
    return {"route_cold_s": round(statistics.median(cold), 3),
            "route_cached_s": round(statistics.median(cached), 3),
            "route_cold_all": [round(s, 3) for s in cold]}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--work", type=Path)
    parser.add_argument("--cameras", nargs="*", type=int, default=[300, 1000])
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--api", action="store_true", help="also time the REST route")
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--one", type=Path, help=argparse.SUPPRESS)  # a child: time one workspace
    parser.add_argument("--runs", type=int, default=1, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.one:
        print(json.dumps(timed_runs(args.one, args.runs)))
        return 0
    if args.work is None:
        parser.error("--work is required")
    report = {"load_before": os.getloadavg(), "sizes": {}}
    for cameras in args.cameras:
        root = workspace_of(args.work, cameras)
        report["sizes"][cameras] = cold_and_cached(root, args.repeats)
        if args.api:
            report["sizes"][cameras] |= route_times(root, args.repeats)
    report["load_after"] = os.getloadavg()
    if args.json:
        print(json.dumps(report))
        return 0
    print(f"load average before {_load(report['load_before'])}, after {_load(report['load_after'])}")
    for cameras, row in report["sizes"].items():
        print(f"{cameras:>5} cameras: cold {row['cold_s']:.2f} s {row['cold_all']} (CPU "
              f"{row['cold_cpu_s']:.2f} s), cached "
              f"{row['cached_s']:.2f} s; cold stages {row['stages_cold']}; "
              f"{row['raised']} raised, {row['runs']} runs")
        if "route_cold_s" in row:
            print(f"{cameras:>5} cameras: GET .../suspects cold {row['route_cold_s']:.2f} s "
                  f"{row['route_cold_all']}, cached {row['route_cached_s']:.3f} s")
    return 0


def _load(values) -> str:
    return " ".join(f"{v:.2f}" for v in values)


if __name__ == "__main__":
    sys.exit(main())
