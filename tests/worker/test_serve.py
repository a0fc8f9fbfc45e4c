"""`guided-sfm serve`: prints the URL once the API answers, restarts a dead worker, stops on SIGTERM."""

import os
import re
import select
import signal
import socket
import subprocess
import sys
import time
import urllib.error
import urllib.request
from pathlib import Path


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def children(pid: int) -> dict[str, int]:
    """The serve process's children by role ('api' or 'worker')."""
    found = {}
    for child in Path(f"/proc/{pid}/task/{pid}/children").read_text().split():
        command = Path(f"/proc/{child}/cmdline").read_bytes().split(b"\0")
        role = next((part.decode() for part in command if part in (b"api", b"worker")), None)
        if role:
            found[role] = int(child)
    return found


def gone(pid: int) -> bool:
    stat = Path(f"/proc/{pid}/stat")
    return not stat.exists() or stat.read_text().split()[2] == "Z"


def wait_for(condition, timeout: float, what: str):
    start = time.monotonic()
    while time.monotonic() < start + timeout:
        value = condition()
        if value:
            print(f"{what}: {time.monotonic() - start:.1f} s")
            return value
        time.sleep(0.3)
    raise AssertionError(f"timed out waiting {timeout} s for {what}")


def first_line(process: subprocess.Popen, timeout: float) -> str:
    """The first line on the process's stdout, failing (not hanging) if none comes in time."""
    start = time.monotonic()
    ready, _, _ = select.select([process.stdout], [], [], timeout)
    assert ready, f"no line from {process.args[2:4]} within {timeout} s (exit code {process.poll()})"
    line = process.stdout.readline()
    print(f"first line after {time.monotonic() - start:.1f} s: {line.strip()!r}")
    return line


def test_serve_supervises_api_and_worker(tmp_path):
    port = free_port()
    env = {k: v for k, v in os.environ.items() if not k.startswith("GUIDED_SFM_")}
    serve = subprocess.Popen([sys.executable, "-m", "guided_sfm.cli", "serve", "--port", str(port),
                              "--data-dir", str(tmp_path / "data")], env=env, stdout=subprocess.PIPE,
                             stderr=subprocess.DEVNULL, text=True)
    try:
        assert first_line(serve, 120).strip() == f"URL: http://127.0.0.1:{port}/"
        with urllib.request.urlopen(f"http://127.0.0.1:{port}/api/v1/health", timeout=5) as response:
            assert response.status == 200
        assert (tmp_path / "data" / "guided_sfm.db").is_file()  # embedded default: SQLite in the data dir
        first = wait_for(lambda: children(serve.pid).get("worker"), 120, "the worker")
        os.killpg(first, signal.SIGKILL)
        second = wait_for(lambda: (children(serve.pid).get("worker") or first) != first
                          and children(serve.pid)["worker"], 120, "a restarted worker")
        assert second != first
        api = children(serve.pid)["api"]
        serve.send_signal(signal.SIGTERM)
        stopping = time.monotonic()
        assert serve.wait(timeout=120) == 0
        print(f"stopped on SIGTERM in {time.monotonic() - stopping:.1f} s")
        assert gone(api) and gone(second)
    finally:
        if serve.poll() is None:
            serve.kill()
            serve.wait()
        serve.stdout.close()


def _health(port: int, path: str = "/api/v1/health") -> int:
    try:
        with urllib.request.urlopen(f"http://127.0.0.1:{port}{path}", timeout=5) as response:
            return response.status
    except urllib.error.HTTPError as exc:
        return exc.code
    except OSError:
        return 0


def test_serve_restarts_a_dead_api_and_starts_nothing_once_stopping(tmp_path):
    port = free_port()
    env = {k: v for k, v in os.environ.items() if not k.startswith("GUIDED_SFM_")}
    env["GUIDED_SFM_SWEEP_SECONDS"] = "1"
    log = open(tmp_path / "serve.log", "w")  # noqa: SIM115  (closed in finally)
    serve = subprocess.Popen([sys.executable, "-m", "guided_sfm.cli", "serve", "--port", str(port),
                              "--data-dir", str(tmp_path / "data")], env=env, stdout=subprocess.PIPE,
                             stderr=log, text=True)
    try:
        assert serve.stdout.readline().strip() == f"URL: http://127.0.0.1:{port}/"
        wait_for(lambda: _health(port, "/api/v1/health/ready") == 200, 60, "ready (worker seen)")
        api = children(serve.pid)["api"]
        os.killpg(api, signal.SIGKILL)
        wait_for(lambda: (children(serve.pid).get("api") or api) != api, 30, "a restarted API")
        wait_for(lambda: _health(port) == 200, 60, "the restarted API to answer")
        worker = children(serve.pid)["worker"]
        os.killpg(worker, signal.SIGKILL)
        time.sleep(0.7)  # the supervisor has seen it and waits before restarting it
        serve.send_signal(signal.SIGTERM)
        assert serve.wait(timeout=60) == 0
        started = re.findall(r"^(api|worker) started", (tmp_path / "serve.log").read_text(), re.M)
        assert started.count("api") == 2 and started.count("worker") == 1, started
    finally:
        if serve.poll() is None:
            serve.kill()
            serve.wait()
        serve.stdout.close()
        log.close()
