"""Load benchmark of the REST API: N concurrent clients, half polling a job's status and half
reading a version's scene, each pacing itself to one request per --pace seconds (50 clients at
0.5 s offer 100 requests/s), then the same clients with no pause (throughput); beside them --team
members (signed up and made viewers) polling presence and their unread notifications as the
editor does (one request per --team-pace seconds each); and, with --login-flood N, how long
`GET /projects` takes while N logins with wrong passwords run at once.

    python benchmarks/bench_api.py                       # starts `guided-sfm serve --sample` in a temp dir
    python benchmarks/bench_api.py --data-dir /tmp/bench     # the same, kept for a quicker rerun
    python benchmarks/bench_api.py --url http://127.0.0.1:8000 --username demo --password ...
    GUIDED_SFM_DATABASE_URL=postgresql+psycopg://... GUIDED_SFM_BROKER_URL=redis://... \
        python benchmarks/bench_api.py                   # the served stack on Postgres + Redis

Prints one JSON document: per phase, requests, errors, throughput (req/s), p50/p99 latency (ms) per
route, and the machine's load average beside them. Without --url it waits for the sample's
reconstruction, then measures on loopback.
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
    # the team members sign up and log in from this one address: above the login throttle's default
    env = {**os.environ, "GUIDED_SFM_LOGIN_ATTEMPTS_PER_ADDRESS": "1000"}
    server = subprocess.Popen(command, stdout=subprocess.PIPE, text=True, stderr=subprocess.DEVNULL,
                              start_new_session=True, env=env)
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


def record(result: dict, elapsed: float, status: str) -> None:
    """One answer's latency; anything but a 200 is an error, counted by its status (or exception)."""
    result["ms"].append(elapsed * 1000)
    if status != "200":
        result["errors"] += 1
        result["error_kinds"][status] = result["error_kinds"].get(status, 0) + 1


async def one_client(base: str, headers: dict, route: str, until: float, pace: float, begin: float,
                     results: dict) -> None:
    """One poller: an untimed first request opens its connection, then it starts at `begin` (the
    clients' begins spread over one pace, so that requests arrive at an even offered rate, not all
    at one instant)."""
    async with httpx.AsyncClient(base_url=base, headers=headers, timeout=60) as client:
        await client.get(route, headers={"Accept-Encoding": "gzip"})
        await asyncio.sleep(max(0.0, begin - time.monotonic()))
        while time.monotonic() < until:
            started = time.perf_counter()
            try:
                status = str((await client.get(route, headers={"Accept-Encoding": "gzip"})).status_code)
            except httpx.HTTPError as error:
                status = type(error).__name__
            elapsed = time.perf_counter() - started
            record(results[route], elapsed, status)
            if pace > elapsed:
                await asyncio.sleep(pace - elapsed)


TeamRoute = tuple[str, str, dict | None]  # method, path, JSON body


async def team_client(base: str, headers: dict, routes: list[TeamRoute], until: float, pace: float,
                      begin: float, results: dict) -> None:
    """One member's editor: presence, then notifications, then presence again, ... from `begin`."""
    async with httpx.AsyncClient(base_url=base, headers=headers, timeout=60) as client:
        await asyncio.sleep(max(0.0, begin - time.monotonic()))
        index = 0
        while time.monotonic() < until:
            method, path, body = routes[index % len(routes)]
            index += 1
            started = time.perf_counter()
            try:
                status = str((await client.request(method, path, json=body)).status_code)
            except httpx.HTTPError as error:
                status = type(error).__name__
            elapsed = time.perf_counter() - started
            record(results[f"{method} {path}"], elapsed, status)
            if pace > elapsed:
                await asyncio.sleep(pace - elapsed)


async def load(base: str, headers: dict, routes: list[str], clients: int, seconds: float,
               pace: float, team: tuple[list[dict], list[TeamRoute], float] = ([], [], 0.0)) -> dict:
    """Client i reads routes[i % len(routes)] only: half the clients on each route; each member of
    `team` (their headers, the routes they cycle through, their pace) polls beside them."""
    members, team_routes, team_pace = team
    names = routes + [f"{method} {path}" for method, path, _ in team_routes if members]
    results = {name: {"ms": [], "errors": 0, "error_kinds": {}} for name in names}
    start = time.monotonic() + 2.0  # every client's connection open before the clock starts
    until = start + seconds
    await asyncio.gather(*(one_client(base, headers, routes[i % len(routes)], until, pace,
                                      start + pace * i / clients, results)
                           for i in range(clients)),
                         *(team_client(base, member, team_routes, until, team_pace,
                                       start + team_pace * i / max(len(members), 1), results)
                           for i, member in enumerate(members)))
    report = {}
    for route, data in results.items():
        report[route] = {"requests": len(data["ms"]), "errors": data["errors"],
                         "error_kinds": data["error_kinds"],
                         "p50_ms": round(percentile(data["ms"], 0.5), 1),
                         "p99_ms": round(percentile(data["ms"], 0.99), 1)}
    total = sum(r["requests"] for r in report.values())
    return {"clients": clients, "team_members": len(members), "seconds": seconds, "pace_s": pace,
            "requests": total,
            "errors": sum(r["errors"] for r in report.values()),
            "throughput_rps": round(total / seconds, 1), "routes": report,
            "load_average": [round(x, 2) for x in os.getloadavg()]}


async def login_flood(base: str, headers: dict, logins: int) -> dict:
    """`GET /projects` latency while `logins` wrong-password logins run at once (throttle and the
    bounded Argon2 slots keep it short; 429s are expected)."""
    async with httpx.AsyncClient(base_url=base, timeout=120) as client:
        async def bad_login(i: int) -> int:
            form = {"username": f"nobody{i % 5}", "password": "wrong"}
            return (await client.post("/api/v1/auth/token", data=form)).status_code

        async def projects() -> float:
            await asyncio.sleep(0.2)  # once the flood is under way
            started = time.perf_counter()
            await client.get("/api/v1/projects", headers=headers)
            return (time.perf_counter() - started) * 1000

        *codes, ms = await asyncio.gather(*(bad_login(i) for i in range(logins)), projects())
    return {"logins": logins, "status_counts": {str(c): codes.count(c) for c in sorted(set(codes))},
            "get_projects_ms": round(ms, 1), "load_average": [round(x, 2) for x in os.getloadavg()]}


def sign_up_members(url: str, owner: dict, pid: int, count: int) -> list[dict]:
    """`count` users (signed up once, reused by a rerun), each a viewer of the project: their headers."""
    headers = []
    with httpx.Client(base_url=url, timeout=60) as client:
        for n in range(count):
            account = {"username": f"bench-member-{n}", "password": "bench-member-password"}
            client.post("/api/v1/users", json=account)  # 409 when an earlier run made it
            client.put(f"/api/v1/projects/{pid}/members/{account['username']}", json={"role": "viewer"},
                       headers=owner).raise_for_status()
            answer = client.post("/api/v1/auth/token", data=account)
            if answer.status_code == 429:
                raise SystemExit("the login throttle refused the members' logins: run the server with "
                                 "GUIDED_SFM_LOGIN_ATTEMPTS_PER_ADDRESS above 2 x --team")
            token = answer.json()["access_token"]
            headers.append({"Authorization": f"Bearer {token}"})
    return headers


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--url", default=None)
    parser.add_argument("--username", default=None)
    parser.add_argument("--password", default=None)
    parser.add_argument("--clients", type=int, default=50)
    parser.add_argument("--seconds", type=float, default=30.0)
    parser.add_argument("--pace", type=float, default=0.5, help="seconds per request per client (paced)")
    parser.add_argument("--team", type=int, default=20, help="members polling presence and notifications")
    parser.add_argument("--team-pace", type=float, default=5.0,
                        help="seconds per request per member (the editor: both every 10 s)")
    parser.add_argument("--login-flood", type=int, default=40, help="parallel wrong logins (0: skip)")
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
            routes = [f"/api/v1/jobs/{job_id}", f"/api/v1/projects/{pid}/versions/{vid}/scene"]
            members = sign_up_members(args.url, headers, pid, args.team)
            team_routes = [("POST", f"/api/v1/projects/{pid}/presence", {"version_id": vid}),
                           ("GET", "/api/v1/notifications?unread=true", None)]
            team = (members, team_routes, args.team_pace)
            report = {phase: asyncio.run(load(args.url, headers, routes, args.clients, args.seconds, pace,
                                              team))
                      for phase, pace in (("paced", args.pace), ("unpaced", 0.0))}
            if args.login_flood:
                report["login_flood"] = asyncio.run(login_flood(args.url, headers, args.login_flood))
            print(json.dumps(report, indent=1))
            return 1 if report["paced"]["errors"] or report["unpaced"]["errors"] else 0
        finally:
            if server is not None:
                os.killpg(server.pid, signal.SIGTERM)
                server.wait(timeout=60)


if __name__ == "__main__":
    sys.exit(main())
