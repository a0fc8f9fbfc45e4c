"""The service's commands: `serve` (API + one supervised worker), `api` and `worker` alone.

cli.py calls register(subparsers). stdout carries the URL and credentials only; logs go to stderr.
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import os
import signal
import subprocess
import sys
import time
import urllib.request

from guided_sfm.settings import Settings

log = logging.getLogger("guided_sfm.serve")
RESTART_BACKOFF = (1, 2, 5, 10, 30)  # seconds before restarting a worker that keeps dying
STOP_GRACE = 15.0


def register(subparsers: argparse._SubParsersAction) -> None:
    serve = subparsers.add_parser("serve", help="migrations, the API and one worker (embedded default)")
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

    settings = Settings.from_env()
    settings.data_dir.mkdir(parents=True, exist_ok=True)
    upgrade(settings.database_url)
    app = create_app(settings, submitter(make_celery(settings)))
    _reconcile(app.state.sessions, settings)
    uvicorn.run(app, host=args.host, port=args.port, log_level="info")


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
    """Runs the API and one worker as child processes; restarts the worker when it dies."""

    def __init__(self, env: dict[str, str], host: str, port: int) -> None:
        self.env, self.host, self.port = env, host, port
        self.api: subprocess.Popen | None = None
        self.worker: subprocess.Popen | None = None
        self.stopping = False
        self.restarts = 0

    def _spawn(self, *command: str) -> subprocess.Popen:
        # Its own session: Ctrl-C reaches only us, and stopping a worker stops its pool and beat too.
        return subprocess.Popen([sys.executable, "-m", "guided_sfm.cli", *command], env=self.env,
                                stdout=sys.stderr, start_new_session=True)

    def start(self) -> None:
        self.api = self._spawn("api", "--host", self.host, "--port", str(self.port))
        self.worker = self._spawn("worker")

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
            if self.api.poll() is not None:
                log.error("the API process exited with %s; stopping", self.api.returncode)
                sys.exit(self.api.returncode or 1)
            if self.worker.poll() is not None:
                delay = RESTART_BACKOFF[min(self.restarts, len(RESTART_BACKOFF) - 1)]
                print(f"worker exited with {self.worker.returncode}; restarting in {delay} s",
                      file=sys.stderr, flush=True)
                _stop_group(self.worker)  # its pool or beat may have outlived it
                time.sleep(delay)
                self.restarts += 1
                self.worker = self._spawn("worker")

    def stop(self) -> None:
        for process in (self.worker, self.api):
            if process is not None:
                _stop_group(process)


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
