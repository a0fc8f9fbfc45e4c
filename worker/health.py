"""`python -m worker.health`: exit 0 when a worker answers a ping (docker-compose healthcheck)."""

from __future__ import annotations

import socket
import sys

from guided_sfm.settings import Settings
from worker.celery_app import make_celery


def main() -> int:
    settings = Settings.from_env()
    if settings.broker_url.startswith("filesystem"):
        return 0  # no broadcast on the filesystem broker; `serve` supervises that worker itself
    replies = make_celery(settings).control.ping(timeout=5.0) or []
    mine = [name for reply in replies for name in reply if name.endswith("@" + socket.gethostname())]
    return 0 if mine else 1


if __name__ == "__main__":
    sys.exit(main())
