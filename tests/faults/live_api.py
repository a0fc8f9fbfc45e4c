"""The API as a real `guided-sfm api` process (uvicorn) on a committed database of the test's own,
with a data dir prepared in-process first (users, a project, a version)."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
import urllib.error
import urllib.request
from pathlib import Path

from tests.conftest import SECRET


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def service_env(data_dir: Path, database_url: str, **settings: object) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("GUIDED_SFM_")}
    values = {"data_dir": data_dir, "database_url": database_url, "secret_key": SECRET, **settings}
    env.update({f"GUIDED_SFM_{k.upper()}": str(v) for k, v in values.items()})
    return env


class LiveApi:
    """`python -m guided_sfm.cli api` on a free port; requests with urllib (one connection each)."""

    def __init__(self, env: dict[str, str], log: Path) -> None:
        self.env, self.log, self.port = env, log, free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.process: subprocess.Popen | None = None

    def start(self, timeout: float = 60.0) -> LiveApi:
        with open(self.log, "ab") as log:
            self.process = subprocess.Popen(
                [sys.executable, "-m", "guided_sfm.cli", "api", "--port", str(self.port)],
                env=self.env, stdout=log, stderr=log, start_new_session=True)
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                raise AssertionError(f"the API exited: {self.log.read_text()[-2000:]}")
            try:
                if self.request("GET", "/api/v1/health", timeout=2)[0] == 200:
                    return self
            except OSError:
                time.sleep(0.2)
        raise AssertionError("the API did not answer")

    def request(self, method: str, path: str, body: object = None, headers: dict | None = None,
                data: bytes | None = None, timeout: float = 60.0) -> tuple[int, dict, dict]:
        """(status, JSON body or {}, headers); 4xx/5xx are returned, not raised."""
        headers = dict(headers or {})
        if body is not None:
            data, headers["Content-Type"] = json.dumps(body).encode(), "application/json"
        request = urllib.request.Request(self.url + path, data=data, method=method, headers=headers)
        try:
            with urllib.request.urlopen(request, timeout=timeout) as response:
                return response.status, _json(response.read()), dict(response.headers)
        except urllib.error.HTTPError as exc:
            return exc.code, _json(exc.read()), dict(exc.headers)

    def kill(self, sig: int = signal.SIGKILL) -> None:
        if self.process is not None and self.process.poll() is None:
            os.killpg(self.process.pid, sig)
            self.process.wait(timeout=30)

    def rss_mb(self) -> float:
        """Resident memory of the API process (uvicorn runs in the process itself)."""
        for line in Path(f"/proc/{self.process.pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
        raise AssertionError("no VmRSS")


def _json(raw: bytes) -> dict:
    try:
        return json.loads(raw) if raw else {}
    except ValueError:
        return {"raw": raw[:200].decode(errors="replace")}
