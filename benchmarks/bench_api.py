"""Load benchmark of the REST API: N concurrent clients polling a job and reading a version's scene,
beside M team members (each signed up and made a viewer) polling presence and their notifications
as the editor does.

    python benchmarks/bench_api.py                       # starts `guided-sfm serve --sample` in a temp dir
    python benchmarks/bench_api.py --data-dir /tmp/bench     # the same, kept for a quicker rerun
    python benchmarks/bench_api.py --url http://127.0.0.1:8000 --username demo --password ...

Prints one JSON document: requests, errors, throughput (req/s), p50/p99 latency (ms) per route.
Without --url it waits for the sample's reconstruction (52 images), then measures on loopback.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import httpx


def percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(round(q * (len(ordered) - 1))))] if ordered else float("nan")


def start_server(data_dir: Path, port: int) -> tuple[subprocess.Popen, str, str]:
    command = [sys.executable, "-m", "guided_sfm.cli", "serve", "--sample", "--port", str(port),
               "--data-dir", str(data_dir)]
    server = subprocess.Popen(command, stdout=subprocess.PIPE, text=True, stderr=subprocess.DEVNULL,
                              start_new_session=True)
    lines = [server.stdout.readline().strip() for _ in range(3)]
    values = dict(line.split(": ", 1) for line in lines)
    return server, values["Username"], values["Password"]


def wait_for_head(client: httpx.Client, timeout: float) -> tuple[int, int, int]:
    """(project id, a job id, the head version id) once the sample is reconstructed."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        projects = client.get("/api/v1/projects").json()
        if projects and projects[0]["head_version_id"]:
            pid = projects[0]["id"]
            job = client.get(f"/api/v1/projects/{pid}/jobs").json()[-1]
            return pid, job["id"], projects[0]["head_version_id"]
        time.sleep(5)
    raise TimeoutError("the sample project has no reconstruction yet")


Route = tuple[str, str, dict | None]  # method, path, JSON body


async def one_client(base: str, headers: dict, routes: list[Route], until: float, results: dict) -> None:
    async with httpx.AsyncClient(base_url=base, headers=headers, timeout=60) as client:
        index = 0
        while time.monotonic() < until:
            method, path, body = routes[index % len(routes)]
            index += 1
            started = time.perf_counter()
            try:
                response = await client.request(method, path, json=body)
                ok = response.status_code == 200
            except httpx.HTTPError:
                ok = False
            results[f"{method} {path}"]["ms"].append((time.perf_counter() - started) * 1000)
            results[f"{method} {path}"]["errors"] += 0 if ok else 1


async def load(base: str, groups: list[tuple[dict, list[Route]]], seconds: float) -> dict:
    """Each (headers, routes) group is one client cycling through its routes."""
    results = {f"{m} {p}": {"ms": [], "errors": 0} for _, routes in groups for m, p, _ in routes}
    until = time.monotonic() + seconds
    await asyncio.gather(*(one_client(base, headers, routes, until, results) for headers, routes in groups))
    clients = len(groups)
    report = {}
    for route, data in results.items():
        report[route] = {"requests": len(data["ms"]), "errors": data["errors"],
                         "p50_ms": round(percentile(data["ms"], 0.5), 1),
                         "p99_ms": round(percentile(data["ms"], 0.99), 1)}
    total = sum(r["requests"] for r in report.values())
    return {"clients": clients, "seconds": seconds, "requests": total,
            "errors": sum(r["errors"] for r in report.values()),
            "throughput_rps": round(total / seconds, 1), "routes": report}


def members(url: str, owner: dict, pid: int, count: int) -> list[dict]:
    """`count` users (signed up once, reused), each a viewer of the project: their headers."""
    headers = []
    with httpx.Client(base_url=url, timeout=60) as client:
        for n in range(count):
            account = {"username": f"bench-member-{n}", "password": "bench-member-password"}
            client.post("/api/v1/users", json=account)  # 409 when it exists from an earlier run
            client.put(f"/api/v1/projects/{pid}/members/{account['username']}", json={"role": "viewer"},
                       headers=owner).raise_for_status()
            token = client.post("/api/v1/auth/token", data=account).json()["access_token"]
            headers.append({"Authorization": f"Bearer {token}"})
    return headers


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--url", default=None)
    parser.add_argument("--username", default=None)
    parser.add_argument("--password", default=None)
    parser.add_argument("--clients", type=int, default=50)
    parser.add_argument("--team", type=int, default=20, help="members polling presence and notifications")
    parser.add_argument("--seconds", type=float, default=30.0)
    parser.add_argument("--port", type=int, default=8731)
    parser.add_argument("--data-dir", default=None, help="keep the served data here (reused next time)")
    parser.add_argument("--wait", type=float, default=3600.0, help="how long to wait for the sample")
    args = parser.parse_args()
    server = None
    with tempfile.TemporaryDirectory(prefix="guided-sfm-bench-") as tmp:
        try:
            if args.url is None:
                data_dir = Path(args.data_dir or tmp)
                server, args.username, args.password = start_server(data_dir, args.port)
                args.url = f"http://127.0.0.1:{args.port}"
            token = httpx.post(f"{args.url}/api/v1/auth/token",
                               data={"username": args.username, "password": args.password}).json()
            headers = {"Authorization": f"Bearer {token['access_token']}"}
            with httpx.Client(base_url=args.url, headers=headers, timeout=60) as client:
                pid, job_id, vid = wait_for_head(client, args.wait)
            pollers = [("GET", f"/api/v1/jobs/{job_id}", None),
                       ("GET", f"/api/v1/projects/{pid}/versions/{vid}/scene", None)]
            team = [("POST", f"/api/v1/projects/{pid}/presence", {"version_id": vid}),
                    ("GET", "/api/v1/notifications?unread=true", None)]
            groups = [(headers, pollers)] * args.clients + [
                (member, team) for member in members(args.url, headers, pid, args.team)]
            report = asyncio.run(load(args.url, groups, args.seconds))
            print(json.dumps(report, indent=1))
            return 1 if report["errors"] else 0
        finally:
            if server is not None:
                os.killpg(server.pid, signal.SIGTERM)
                server.wait(timeout=60)


if __name__ == "__main__":
    sys.exit(main())
