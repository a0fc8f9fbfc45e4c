"""A restart of the database under a real API process: a Postgres of the test's own (initdb and
pg_ctl on a free port, run as the `postgres` user when the test runs as root). While it is down the
API answers 503, never 500; once it is back the API answers again without a restart."""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

import pytest

from guided_sfm.db.migrate import upgrade
from tests.faults.conftest import login
from tests.faults.live_api import LiveApi, free_port, service_env


class OwnPostgres:
    def __init__(self, folder, port: int) -> None:
        self.folder, self.port = folder, port
        self.prefix = ["runuser", "-u", "postgres", "--"] if os.geteuid() == 0 else []

    def run(self, *command: str) -> None:
        subprocess.run([*self.prefix, *command], check=True, capture_output=True, timeout=120)

    def init(self) -> None:
        if self.prefix:  # the postgres user cannot enter pytest's root-only tmp folders
            shutil.chown(self.folder, "postgres", "postgres")
        self.run("initdb", "-D", str(self.folder / "data"), "-A", "trust", "-U", "postgres")

    def start(self) -> None:
        self.run("pg_ctl", "-D", str(self.folder / "data"), "-l", str(self.folder / "log"), "-w",
                 "-o", f"-p {self.port} -k {self.folder} -c listen_addresses=127.0.0.1", "start")

    def stop(self) -> None:
        subprocess.run([*self.prefix, "pg_ctl", "-D", str(self.folder / "data"), "-m", "fast", "-w", "stop"],
                       capture_output=True, timeout=120)


def test_the_api_answers_503_while_its_database_restarts(tmp_path):
    if shutil.which("initdb") is None or shutil.which("pg_ctl") is None:
        pytest.skip("initdb and pg_ctl are not installed")
    postgres = OwnPostgres(Path(tempfile.mkdtemp(prefix="gsfm-pg-")), free_port())
    try:
        postgres.init()
    except (subprocess.CalledProcessError, LookupError, PermissionError) as exc:
        pytest.skip(f"cannot run a Postgres of the test's own here ({exc})")
    postgres.start()
    api = None
    try:
        url = f"postgresql+psycopg://postgres@127.0.0.1:{postgres.port}/postgres"
        upgrade(url)
        env = service_env(tmp_path / "data", url, broker_url="memory://")
        api = LiveApi(env, tmp_path / "api.log").start()
        headers = login(api, "ops")
        assert api.request("GET", "/api/v1/projects", headers=headers)[0] == 200
        postgres.stop()
        for path in ("/api/v1/projects", "/api/v1/health"):
            status, body, _ = api.request("GET", path, headers=headers)
            assert status == 503, (path, status, body)
        status, body, _ = api.request("POST", "/api/v1/projects", {"name": "p"}, headers)
        assert status == 503 and "database" in body["detail"], body
        postgres.start()
        deadline = time.monotonic() + 30
        while api.request("GET", "/api/v1/health")[0] != 200 and time.monotonic() < deadline:
            time.sleep(0.5)
        assert api.request("GET", "/api/v1/projects", headers=headers)[0] == 200
        assert api.request("POST", "/api/v1/projects", {"name": "p"}, headers)[0] == 201
    finally:
        if api is not None:
            api.kill()
        postgres.stop()
        shutil.rmtree(postgres.folder, ignore_errors=True)
