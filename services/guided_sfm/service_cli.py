"""The service's commands: `serve` (API + one supervised worker), `api` and `worker` alone.

cli.py calls register(subparsers). stdout carries the URL and credentials only; logs go to stderr.
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import gc
import logging
import os
import signal
import subprocess
import sys
import time
import urllib.request

from guided_sfm.settings import Settings

log = logging.getLogger("guided_sfm.serve")
RESTART_BACKOFF = (1, 2, 5, 10, 30)  # seconds before restarting a process that keeps dying
STOP_GRACE = 15.0
KEEP_ALIVE_SECONDS = 75


def register(subparsers: argparse._SubParsersAction) -> None:
    serve = subparsers.add_parser("serve", help="migrations, the API and one worker, both supervised")
    serve.add_argument("--host", default="127.0.0.1")
    serve.add_argument("--port", type=int, default=8000)
    serve.add_argument("--data-dir", default=None, help="default: $GUIDED_SFM_DATA_DIR or ./data")
    serve.add_argument("--sample", action="store_true", help="a user and a project with the sample")
    serve.set_defaults(func=cmd_serve)
    api = subparsers.add_parser("api", help="the API process alone (runs migrations first)")
    api.add_argument("--host", default="127.0.0.1")
    api.add_argument("--port", type=int, default=8000)
    api.set_defaults(func=cmd_api)
    worker = subparsers.add_parser("worker", help="one Celery worker (one job at a time) and the sweeper")
    worker.set_defaults(func=cmd_worker)


def cmd_api(args: argparse.Namespace) -> None:
    import PIL.Image  # noqa: F401  (before pycolmap, see cli.py)
    import uvicorn

    from guided_sfm.api.app import create_app
    from guided_sfm.db.migrate import upgrade
    from worker.celery_app import make_celery, submitter
    from worker.health import readiness

    settings = Settings.from_env()
    settings.data_dir.mkdir(parents=True, exist_ok=True)
    upgrade(settings.database_url)
    celery = make_celery(settings)
    app = create_app(settings, submitter(celery), readiness=functools.partial(readiness, settings, celery))
    _reconcile(app.state.sessions, settings)
    _tune_gc()
    # proxy_headers off: the client address is ours to judge (GUIDED_SFM_TRUSTED_PROXIES, api/throttle.py)
    # keep-alive beyond the editor's 10 s polls: at uvicorn's 5 s, an idle connection closed as the
    # next poll was sent failed that request (bench_api: ReadError)
    uvicorn.run(app, host=args.host, port=args.port, log_level="info", proxy_headers=False,
                timeout_keep_alive=KEEP_ALIVE_SECONDS)


def _tune_gc() -> None:
    """Fewer, cheaper garbage collections while serving. A request allocates thousands of objects
    (ORM rows, pydantic models), so the default threshold (700) collected every few requests, and each
    full collection walked every module and route loaded at start, in a pause every request waited
    out. Startup's objects are frozen out of collection; bench_api (34 s under load): 1,112 -> 386
    collections, 1.8 -> 0.7 s spent collecting."""
    gc.collect()
    gc.freeze()
    gc.set_threshold(50_000, 50, 100)


def _reconcile(sessions, settings: Settings) -> None:
    """Orphans a crash left (files without rows) go before the API answers."""
    from guided_sfm.actions.reconcile import reconcile_store

    try:
        reconcile_store(sessions, settings)
    except Exception:  # never keep the API from starting; the worker's sweeper tries again
        log.warning("reconcile at start failed", exc_info=True)


def cmd_worker(_args: argparse.Namespace) -> None:
    from worker.celery_app import make_celery

    settings = Settings.from_env()
    settings.data_dir.mkdir(parents=True, exist_ok=True)
    make_celery(settings).worker_main([
        "worker", "--loglevel=INFO", "--concurrency=1", "--without-mingle", "--without-gossip",
        f"--hostname=guided-sfm-{os.getpid()}@%h",
    ])


def cmd_serve(args: argparse.Namespace) -> None:
    from guided_sfm.db.migrate import upgrade

    settings = Settings.from_env(**({"data_dir": args.data_dir} if args.data_dir else {}))
    settings.data_dir.mkdir(parents=True, exist_ok=True)
    upgrade(settings.database_url)
    env = {**os.environ, "GUIDED_SFM_DATA_DIR": str(settings.data_dir)}
    supervisor = Supervisor(env, args.host, args.port)
    signal.signal(signal.SIGTERM, supervisor.request_stop)
    signal.signal(signal.SIGINT, supervisor.request_stop)
    try:
        supervisor.start()
        credentials = _sample(settings) if args.sample else None
        url = f"http://{args.host}:{args.port}/"
        if supervisor.wait_for_api(url + "api/v1/health"):
            print(f"URL: {url}", flush=True)
            if credentials:
                print(f"Username: {credentials['username']}\nPassword: {credentials['password']}", flush=True)
        supervisor.watch()
    finally:
        supervisor.stop()


def _sample(settings: Settings) -> dict:
    import PIL.Image  # noqa: F401  (before pycolmap, see cli.py)

    from guided_sfm.actions import sample_project
    from guided_sfm.api.security import hash_password
    from guided_sfm.db.session import make_sessionmaker
    from worker.celery_app import make_celery, submitter

    return sample_project.ensure(make_sessionmaker(settings), settings, submitter(make_celery(settings)),
                                 hash_password)


class Supervisor:
    """Runs the API and one worker as child processes and restarts either when it dies (with a
    growing delay when it keeps dying); never starts one again once asked to stop."""

    def __init__(self, env: dict[str, str], host: str, port: int) -> None:
        self.env, self.host, self.port = env, host, port
        self.commands = {"api": ("api", "--host", host, "--port", str(port)), "worker": ("worker",)}
        self.processes: dict[str, subprocess.Popen] = {}
        self.restarts = {"api": 0, "worker": 0}
        self.stopping = False

    @property
    def api(self) -> subprocess.Popen | None:
        return self.processes.get("api")

    @property
    def worker(self) -> subprocess.Popen | None:
        return self.processes.get("worker")

    def _spawn(self, role: str) -> subprocess.Popen:
        # Its own session: Ctrl-C reaches only us, and stopping a worker stops its pool and beat too.
        process = subprocess.Popen([sys.executable, "-m", "guided_sfm.cli", *self.commands[role]],
                                   env=self.env, stdout=sys.stderr, start_new_session=True)
        print(f"{role} started (pid {process.pid})", file=sys.stderr, flush=True)
        return process

    def start(self) -> None:
        for role in self.commands:
            self.processes[role] = self._spawn(role)

    def request_stop(self, *_args: object) -> None:
        self.stopping = True

    def wait_for_api(self, health_url: str, timeout: float = 120.0) -> bool:
        deadline = time.monotonic() + timeout
        while not self.stopping and time.monotonic() < deadline and self.api.poll() is None:
            try:
                with urllib.request.urlopen(health_url, timeout=2) as response:
                    if response.status == 200:
                        return True
            except OSError:
                time.sleep(0.3)
        return False

    def watch(self) -> None:
        while not self.stopping:
            time.sleep(0.5)
            for role, process in list(self.processes.items()):
                if not self.stopping and process.poll() is not None:
                    self._restart(role, process)

    def _restart(self, role: str, process: subprocess.Popen) -> None:
        delay = RESTART_BACKOFF[min(self.restarts[role], len(RESTART_BACKOFF) - 1)]
        print(f"{role} exited with {process.returncode}; restarting in {delay} s",
              file=sys.stderr, flush=True)
        _stop_group(process)  # its pool or beat may have outlived it
        deadline = time.monotonic() + delay
        while time.monotonic() < deadline:
            if self.stopping:
                return  # asked to stop meanwhile: nothing is started again
            time.sleep(0.1)
        self.restarts[role] += 1
        self.processes[role] = self._spawn(role)

    def stop(self) -> None:
        for role in ("worker", "api"):
            if role in self.processes:
                _stop_group(self.processes[role])


def _stop_group(process: subprocess.Popen) -> None:
    """SIGTERM the leader (Celery's warm shutdown stops its own pool), SIGKILL the group after the
    grace period: signalling the pool directly can leave the worker waiting for a child forever."""
    with contextlib.suppress(ProcessLookupError):
        os.kill(process.pid, signal.SIGTERM)
    with contextlib.suppress(subprocess.TimeoutExpired):
        process.wait(timeout=STOP_GRACE)
    with contextlib.suppress(ProcessLookupError):
        os.killpg(process.pid, signal.SIGKILL)
    process.wait()
