"""`python -m tests.faults.beat_writer DATABASE_URL JOB_ID SECONDS`: writes a running job's row as a
worker does (heartbeat and progress, each its own short transaction) as fast as it can."""

from __future__ import annotations

import signal
import sys
import time

from guided_sfm import jobs
from guided_sfm.db.session import make_engine, make_sessionmaker, session_scope


def main(database_url: str, job_id: int, seconds: float) -> int:
    sessions = make_sessionmaker(make_engine(database_url))
    report, deadline, writes = jobs.Reporter(sessions, job_id, interval=0.0), time.monotonic() + seconds, 0
    stop = []
    signal.signal(signal.SIGTERM, lambda *_: stop.append(True))
    print("writing", flush=True)
    while time.monotonic() < deadline and not stop:
        with session_scope(sessions) as session:
            jobs.beat(session, job_id)
        report("map", (writes % 100) / 100)
        writes += 2
        time.sleep(0.005)
    print(writes, flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], int(sys.argv[2]), float(sys.argv[3])))
