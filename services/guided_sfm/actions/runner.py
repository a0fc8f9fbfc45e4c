"""Run one job end to end: claim the row, heartbeat, dispatch by kind, publish or record the failure."""

from __future__ import annotations

import contextlib
import logging
import os
import shutil
import threading
import time
from collections.abc import Callable
from pathlib import Path

from sqlalchemy import func, select
from sqlalchemy.orm import Session, sessionmaker

from guided_sfm import jobs
from guided_sfm.actions import activity, apply_edit, import_workspace, reconstruct, webhooks
from guided_sfm.actions.context import JobContext, Produced
from guided_sfm.actions.publish import publish
from guided_sfm.actions.store_wait import StoreOutage, StoreWait
from guided_sfm.core.errors import Cancelled, DomainError
from guided_sfm.core.sfm import CancelToken
from guided_sfm.core.stage_clock import StageClock
from guided_sfm.db.models import Image, Job, Version
from guided_sfm.db.session import session_scope
from guided_sfm.errors import without_paths
from guided_sfm.settings import Settings
from guided_sfm.storage import Store, open_store

log = logging.getLogger(__name__)
OVERRUN_GRACE_BEATS = 5  # heartbeats a job past its limit gets to notice the cancel before its process exits
EXIT_OVERRUN = 70
ACTIONS: dict[str, Callable[[JobContext, Path], Produced]] = {
    "reconstruct": reconstruct.run,
    "apply": apply_edit.run,
    "import": import_workspace.run,
}


class JobToken(CancelToken):
    """The core's cancel token, which also says when it was the time limit that cancelled."""

    def __init__(self) -> None:
        super().__init__()
        self.overrun: str | None = None


class Heartbeat(threading.Thread):
    """Touches the job row while the action runs (pycolmap may not report for minutes), turns the
    row's cancel flag into the token the core checks, and enforces the job's time limit: the token
    first, then, if the action does not stop (stuck in C code, or a query that never ends), the job
    is failed and this process exits so the worker's pool replaces it and runs the next job."""

    def __init__(self, sessions: sessionmaker[Session], job_id: int, token: JobToken, interval: float,
                 limit: float) -> None:
        super().__init__(name=f"heartbeat-{job_id}", daemon=True)
        self.sessions, self.job_id, self.token, self.interval = sessions, job_id, token, interval
        self.limit, self.deadline = limit, time.monotonic() + limit
        self.stopped = threading.Event()

    def run(self) -> None:
        while not self.stopped.wait(self.interval):
            if time.monotonic() > self.deadline:
                self.overrun()
            try:
                with session_scope(self.sessions) as session:
                    if jobs.beat(session, self.job_id):
                        self.token.cancel()
            except Exception:  # database away or busy: the next beat retries; never stop beating
                log.warning("job %s: heartbeat skipped", self.job_id, exc_info=True)

    def overrun(self) -> None:
        message = (f"the job exceeded its time limit of {self.limit:.0f} s (GUIDED_SFM_JOB_BASE_SECONDS "
                   "+ GUIDED_SFM_JOB_SECONDS_PER_IMAGE x images); the project's head is unchanged")
        if self.token.overrun is None:
            self.token.overrun = message
            self.token.cancel()
        elif time.monotonic() > self.deadline + OVERRUN_GRACE_BEATS * self.interval:
            log.error("job %s: past its time limit and not stopping; failing it and exiting", self.job_id)
            with contextlib.suppress(Exception), session_scope(self.sessions) as session:
                jobs.finish(session, self.job_id, "failed", error=message)
                session.commit()
            os._exit(EXIT_OVERRUN)

    def stop(self) -> None:
        self.stopped.set()
        self.join()


def time_limit(sessions: sessionmaker[Session], settings: Settings, project_id: int) -> float:
    """A job's time limit grows with its project: a base plus a share per image."""
    with session_scope(sessions) as session:
        count = session.scalar(select(func.count()).select_from(Image).where(Image.project_id == project_id))
    return settings.job_seconds(count or 0)


def run_job(sessions: sessionmaker[Session], settings: Settings, job_id: int) -> str | None:
    """Run the next queued job in the queue's order (jobs.QUEUE_ORDER), which is not always the job
    whose message woke the worker: each message runs one job, so every job still runs once. Returns
    the job's final state, or None when nothing was queued (a duplicate message)."""
    with session_scope(sessions) as session:
        woken_by, job_id = job_id, jobs.claim_next(session)
        if job_id is None:
            log.info("job %s's message found no queued job; nothing to do", woken_by)
            return None
        job = session.get(Job, job_id)
        session.expunge(job)
    token = JobToken()
    limit = time_limit(sessions, settings, job.project_id)
    heartbeat = Heartbeat(sessions, job_id, token, settings.heartbeat_seconds, limit)
    heartbeat.start()
    try:
        state = _run(sessions, settings, job, token)
    finally:
        heartbeat.stop()
    log_end(sessions, job_id)
    return state


def log_end(sessions: sessionmaker[Session], job_id: int) -> None:
    """The job's end in the activity log and its author's notifications (the job stays ended if
    this fails: the log is written after the outcome, never instead of it)."""
    try:
        with session_scope(sessions) as session:
            activity.job_ended(session, job_id)
    except Exception:  # a lost log line must never turn an ended job into a crash
        log.warning("job %s: its end could not be logged", job_id, exc_info=True)


def _run(sessions: sessionmaker[Session], settings: Settings, job: Job, token: JobToken) -> str:
    store = open_store(settings)
    reporter = jobs.Reporter(sessions, job.id)
    clock = StageClock(reporter)
    wait = StoreWait(settings.store_wait_seconds, lambda message: reporter.write(message=message), token,
                     lambda: store.answered_at)
    try:
        with store.staging(job.project_id, prefix=f"job-{job.id}-") as work:
            context = JobContext(settings, store, sessions, job, clock, token, work)
            # the store away: the action runs again on emptied scratch, the publish under a new
            # key, and neither holds a transaction while it waits
            produced = wait.run(lambda: ACTIONS[job.kind](context, _emptied(work) / "workspace"))
            token.check()  # a cancel that arrived after the last step still wins
            produced.timings = clock.report()
            version = wait.run(lambda: _publish(sessions, store, job, produced))
        log.info("job %s (%s) produced version %s; %s", job.id, job.kind, version.id, produced.timings)
        return "succeeded"
    except Cancelled:
        if token.overrun:
            return _end(sessions, job.id, "failed", clock, error=token.overrun)
        return _end(sessions, job.id, "cancelled", clock, message="cancelled by request")
    except (DomainError, StoreOutage) as exc:
        return _end(sessions, job.id, "failed", clock, error=str(exc))
    except Exception as exc:  # any crash is recorded on the row; the head stays as it was
        log.exception("job %s crashed", job.id)
        return _end(sessions, job.id, "failed", clock, error=f"{type(exc).__name__}: {exc}")


def _emptied(folder: Path) -> Path:
    """The folder with nothing in it (a try that met the store away may have left half its inputs)."""
    for child in folder.iterdir():
        if child.is_dir() and not child.is_symlink():
            shutil.rmtree(child)
        else:
            child.unlink()
    return folder


def _publish(sessions: sessionmaker[Session], store: Store, job: Job, produced: Produced) -> Version:
    with session_scope(sessions) as session:
        return publish(session, store, job, produced)


def _end(sessions: sessionmaker[Session], job_id: int, state: str, clock: StageClock, **values: str) -> str:
    values = {key: without_paths(text) for key, text in values.items()}  # users see these; paths stay here
    with session_scope(sessions) as session:
        if jobs.finish(session, job_id, state, timings=clock.report(), **values):
            webhooks.job_finished(session, session.get(Job, job_id), state, error=values.get("error"))
        session.commit()
    log.info("job %s ended %s %s", job_id, state, values)
    return state
