"""Run one job end to end: claim the row, heartbeat, dispatch by kind, publish or record the failure."""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from pathlib import Path

from sqlalchemy.exc import OperationalError
from sqlalchemy.orm import Session, sessionmaker

from guided_sfm import jobs
from guided_sfm.actions import activity, apply_edit, import_workspace, reconstruct
from guided_sfm.actions.context import JobContext, Produced
from guided_sfm.actions.publish import publish
from guided_sfm.core.errors import Cancelled, DomainError
from guided_sfm.core.sfm import CancelToken
from guided_sfm.core.stage_clock import StageClock
from guided_sfm.db.models import Job
from guided_sfm.db.session import session_scope
from guided_sfm.settings import Settings
from guided_sfm.storage import ArtifactStore

log = logging.getLogger(__name__)
ACTIONS: dict[str, Callable[[JobContext, Path], Produced]] = {
    "reconstruct": reconstruct.run,
    "apply": apply_edit.run,
    "import": import_workspace.run,
}


class Heartbeat(threading.Thread):
    """Touches the job row while the action runs (pycolmap may not report for minutes) and turns
    the row's cancel flag into the token the core checks."""

    def __init__(self, sessions: sessionmaker[Session], job_id: int, token: CancelToken, interval: float):
        super().__init__(name=f"heartbeat-{job_id}", daemon=True)
        self.sessions, self.job_id, self.token, self.interval = sessions, job_id, token, interval
        self.stopped = threading.Event()

    def run(self) -> None:
        while not self.stopped.wait(self.interval):
            try:
                with session_scope(self.sessions) as session:
                    if jobs.beat(session, self.job_id):
                        self.token.cancel()
            except OperationalError:
                log.warning("job %s: heartbeat skipped (database busy)", self.job_id)

    def stop(self) -> None:
        self.stopped.set()
        self.join()


def run_job(sessions: sessionmaker[Session], settings: Settings, job_id: int) -> str | None:
    """Run a queued job; returns its final state, or None when it was not queued (a duplicate)."""
    with session_scope(sessions) as session:
        if not jobs.claim(session, job_id):
            log.info("job %s is not queued any more; nothing to do", job_id)
            return None
        job = session.get(Job, job_id)
        session.expunge(job)
    token = CancelToken()
    heartbeat = Heartbeat(sessions, job_id, token, settings.heartbeat_seconds)
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
    except OperationalError:
        log.warning("job %s: its end could not be logged (database busy)", job_id, exc_info=True)


def _run(sessions: sessionmaker[Session], settings: Settings, job: Job, token: CancelToken) -> str:
    store = ArtifactStore(settings.artifacts_dir)
    clock = StageClock(jobs.Reporter(sessions, job.id))
    context = JobContext(settings, store, sessions, job, clock, token)
    try:
        with store.staging(job.project_id, prefix=f"job-{job.id}-") as work:
            produced = ACTIONS[job.kind](context, work / "workspace")
            token.check()  # a cancel that arrived after the last step still wins
            produced.timings = clock.report()
            with session_scope(sessions) as session:
                version = publish(session, store, job, produced)
        log.info("job %s (%s) produced version %s; %s", job.id, job.kind, version.id, produced.timings)
        return "succeeded"
    except Cancelled:
        return _end(sessions, job.id, "cancelled", clock, message="cancelled by request")
    except DomainError as exc:
        return _end(sessions, job.id, "failed", clock, error=str(exc))
    except Exception as exc:  # any crash is recorded on the row; the head stays as it was
        log.exception("job %s crashed", job.id)
        return _end(sessions, job.id, "failed", clock, error=f"{type(exc).__name__}: {exc}")


def _end(sessions: sessionmaker[Session], job_id: int, state: str, clock: StageClock, **values: str) -> str:
    with session_scope(sessions) as session:
        jobs.finish(session, job_id, state, timings=clock.report(), **values)
        session.commit()
    log.info("job %s ended %s %s", job_id, state, values)
    return state
