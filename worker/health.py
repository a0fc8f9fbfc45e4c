"""Worker health: `python -m worker.health` exits 0 when a worker of this host answers a ping
(docker-compose healthcheck); readiness() names what is down of the broker and the workers for the
API's /health/ready."""

from __future__ import annotations

import os
import socket
import sys
import time

from celery import Celery

from guided_sfm.settings import Settings
from worker.celery_app import make_celery
from worker.presence import PRESENCE_PERIODS, presence_dir


def readiness(settings: Settings, app: Celery) -> dict[str, str]:
    """{part: problem} for the broker and the workers; empty when both are fine."""
    if settings.broker_url.startswith("filesystem"):
        return _filesystem(settings)
    try:
        with app.connection_for_read() as conn:
            conn.ensure_connection(max_retries=1, timeout=2)
    except Exception as exc:  # kombu's and redis's errors alike
        return {"broker": f"the broker does not answer ({type(exc).__name__})",
                "workers": "unknown while the broker is down"}
    replies = app.control.ping(timeout=1.0) or []
    return {} if replies else {"workers": "no worker answered a ping within 1 s"}


def _filesystem(settings: Settings) -> dict[str, str]:
    problems = {}
    queue = settings.broker_dir / "queue"
    if not (queue.is_dir() and os.access(queue, os.W_OK)):
        problems["broker"] = "the filesystem broker's queue folder is missing or not writable"
    cutoff = time.time() - PRESENCE_PERIODS * settings.sweep_seconds
    folder = presence_dir(settings)
    alive = [p for p in folder.iterdir() if p.stat().st_mtime > cutoff] if folder.is_dir() else []
    if not alive:
        problems["workers"] = f"no worker seen in the last {PRESENCE_PERIODS * settings.sweep_seconds:.0f} s"
    return problems


def main() -> int:
    settings = Settings.from_env()
    if settings.broker_url.startswith("filesystem"):
        return 0  # no broadcast on the filesystem broker; `serve` supervises that worker itself
    replies = make_celery(settings).control.ping(timeout=5.0) or []
    mine = [name for reply in replies for name in reply if name.endswith("@" + socket.gethostname())]
    return 0 if mine else 1


if __name__ == "__main__":
    sys.exit(main())
