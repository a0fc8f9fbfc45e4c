"""The periodic sweep: resend queued jobs whose message was lost; re-run (once) or fail jobs whose
worker died. It runs as a timer thread in every worker's main process rather than as a beat task:
beat messages would queue up behind a long job (concurrency 1) and bury the next job's message."""

from __future__ import annotations

import logging
import os
import socket
import threading
import time
from collections.abc import Callable

from sqlalchemy.orm import Session, sessionmaker

from guided_sfm import jobs
from guided_sfm.actions import webhooks
from guided_sfm.actions.reconcile import reconcile_store
from guided_sfm.actions.runner import log_end
from guided_sfm.db.session import make_sessionmaker, session_scope
from guided_sfm.settings import Settings
from worker.presence import touch_presence

log = logging.getLogger(__name__)


def sweep(sessions: sessionmaker[Session], settings: Settings, submit: Callable[[int], None]) -> dict:
    with session_scope(sessions) as session:
        requeued, failed = jobs.recover_stale(session, settings.stale_seconds, settings.max_attempts)
        resend = jobs.lost_messages(session, settings.requeue_seconds)
    for job_id in requeued + resend:
        submit(job_id)
    for job_id in failed:
        log_end(sessions, job_id)
    if failed:
        with session_scope(sessions) as session:
            webhooks.jobs_failed_by_sweep(session, failed)
    if requeued or failed or resend:
        log.warning("sweep: jobs whose worker stopped: requeued %s, failed %s; resent lost messages %s",
                    requeued, failed, resend)
    return {"requeued": requeued, "failed": failed, "resent": resend}


class Sweeper(threading.Thread):
    """Calls sweep() now and then every settings.sweep_seconds until stopped, and reconciles files
    with rows every orphan_grace_seconds. Any error (database or broker away: their exception types
    vary by driver and transport) is logged and the next round waits longer, up to 4 periods."""

    def __init__(self, settings: Settings, submit: Callable[[int], None]) -> None:
        super().__init__(name="guided-sfm-sweeper", daemon=True)
        self.settings, self.submit = settings, submit
        self.stopped = threading.Event()
        self.failures, self.reconciled_at = 0, float("-inf")
        self.name_on_host = f"{socket.gethostname()}-{os.getpid()}"

    def run(self) -> None:
        sessions = make_sessionmaker(self.settings)
        try:
            while True:
                try:
                    self.round(sessions)
                    self.failures = 0
                except Exception:
                    self.failures += 1
                    log.warning("sweep failed (%s in a row); retrying", self.failures, exc_info=True)
                if self.stopped.wait(self.settings.sweep_seconds * min(1 + self.failures, 4)):
                    return
        finally:
            sessions.kw["bind"].dispose()

    def round(self, sessions: sessionmaker[Session]) -> None:
        if self.settings.broker_url.startswith("filesystem"):
            touch_presence(self.settings, self.name_on_host)
        sweep(sessions, self.settings, self.submit)
        if time.monotonic() - self.reconciled_at >= self.settings.orphan_grace_seconds:
            reconcile_store(sessions, self.settings)
            self.reconciled_at = time.monotonic()

    def stop(self) -> None:
        self.stopped.set()
