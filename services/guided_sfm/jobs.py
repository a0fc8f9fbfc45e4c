"""The job state machine on its DB row: create, claim, report (throttled), finish, cancel, sweep.

The row is the truth (the Celery result backend is not used); every transition is a conditional
UPDATE so a duplicated message or a sweeper racing a worker cannot run a job twice.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from datetime import timedelta
from typing import Any

from sqlalchemy import case, select, update
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session, sessionmaker

from guided_sfm.db.models import Job, Project, utcnow
from guided_sfm.db.session import session_scope
from guided_sfm.errors import Conflict

log = logging.getLogger(__name__)
DONE = "done"  # every ended job's stage (design.md); its state says how it ended
REPORT_SECONDS = 1.0  # progress writes are throttled to about one a second


def create(session: Session, project: Project, kind: str, user_id: int | None,
           params: dict[str, Any] | None = None, base_version_id: int | None = None) -> Job:
    """Insert a queued job (flushed, not committed); Conflict when the project has an active job."""
    job = Job(project_id=project.id, kind=kind, state="queued", stage="queued", progress=0.0,
              message="", params=params or {}, created_by=user_id, cancel_requested=False,
              attempts=0, base_version_id=base_version_id, enqueued_at=utcnow())
    try:
        with session.begin_nested():
            session.add(job)
    except IntegrityError as exc:  # the partial unique index on active jobs
        raise Conflict(f"project {project.id} already has a queued or running job") from exc
    return job


def claim(session: Session, job_id: int) -> bool:
    """queued -> running, atomically; False when the job is no longer queued (already taken)."""
    stamp = utcnow()
    result = session.execute(
        update(Job).where(Job.id == job_id, Job.state == "queued")
        .values(state="running", stage="starting", started_at=stamp, heartbeat_at=stamp,
                attempts=Job.attempts + 1)
    )
    session.commit()
    return result.rowcount == 1


# The queue's order: interactive applies (seconds) before reconstructions and imports (minutes to
# hours), then first come first served; one active job per project keeps projects from crowding out.
QUEUE_ORDER = (case((Job.kind == "apply", 0), else_=1), Job.created_at, Job.id)


def queued_in_order(session: Session) -> list[int]:
    """Every queued job's id, next to run first."""
    return list(session.scalars(select(Job.id).where(Job.state == "queued").order_by(*QUEUE_ORDER)))


def claim_next(session: Session) -> int | None:
    """Claim the first queued job in the queue's order that no other worker took first; its id."""
    for job_id in queued_in_order(session):
        if claim(session, job_id):
            return job_id
    return None


def queue_positions(session: Session) -> dict[int, int]:
    """{job id: position} of the queued jobs (1 = next to run)."""
    return {job_id: index for index, job_id in enumerate(queued_in_order(session), start=1)}


def finish(session: Session, job_id: int, state: str, *, message: str = "", error: str | None = None,
           version_id: int | None = None, timings: dict[str, Any] | None = None) -> bool:
    """running -> succeeded/failed/cancelled; False (nothing changed) if someone already ended it."""
    values: dict[str, Any] = {"state": state, "finished_at": utcnow(), "stage": DONE, "error": error,
                              "timings": timings}
    if message:
        values["message"] = message
    if version_id is not None:
        values["version_id"] = version_id
    if state == "succeeded":
        values["progress"] = 1.0
    result = session.execute(update(Job).where(Job.id == job_id, Job.state == "running").values(**values))
    return result.rowcount == 1


def request_cancel(session: Session, job: Job) -> None:
    """A queued job is cancelled at once; a running one gets the flag its worker checks."""
    if job.state == "queued":
        session.execute(update(Job).where(Job.id == job.id, Job.state == "queued").values(
            state="cancelled", stage=DONE, finished_at=utcnow(),
            message="cancelled before it started"))
    elif job.state == "running":
        session.execute(update(Job).where(Job.id == job.id).values(cancel_requested=True))
    else:
        raise Conflict(f"job {job.id} already ended ({job.state})")
    session.commit()
    session.refresh(job)


class Reporter:
    """progress(stage, fraction) for the core; writes the row at most every REPORT_SECONDS."""

    def __init__(self, sessions: sessionmaker[Session], job_id: int, interval: float = REPORT_SECONDS):
        self.sessions, self.job_id, self.interval = sessions, job_id, interval
        self.last_write, self.stage = 0.0, ""

    def __call__(self, stage: str, fraction: float) -> None:
        moment = time.monotonic()
        if stage == self.stage and moment - self.last_write < self.interval:
            return
        self.stage, self.last_write = stage, moment
        self.write(stage=stage, progress=min(max(float(fraction), 0.0), 1.0))

    def write(self, **values: Any) -> None:
        try:
            with session_scope(self.sessions) as session:
                session.execute(update(Job).where(Job.id == self.job_id, Job.state == "running")
                                .values(heartbeat_at=utcnow(), **values))
                session.commit()
        except Exception:  # database busy or away: progress is advisory, the next write retries
            log.warning("job %s: progress write skipped", self.job_id, exc_info=True)


def beat(session: Session, job_id: int) -> bool:
    """Touch the heartbeat; returns whether a cancel was requested."""
    session.execute(update(Job).where(Job.id == job_id, Job.state == "running").values(heartbeat_at=utcnow()))
    session.commit()
    return bool(session.scalar(select(Job.cancel_requested).where(Job.id == job_id)))


def lost_messages(session: Session, older_than: float) -> list[int]:
    """Queued jobs not (re)submitted for `older_than` seconds; marks them resubmitted now."""
    cutoff = utcnow() - timedelta(seconds=older_than)
    ids = list(session.scalars(select(Job.id).where(Job.state == "queued", Job.enqueued_at < cutoff)))
    if ids:
        session.execute(update(Job).where(Job.id.in_(ids)).values(enqueued_at=utcnow()))
    session.commit()
    return ids


def recover_stale(session: Session, older_than: float, max_attempts: int = 2) -> tuple[list[int], list[int]]:
    """Running jobs whose heartbeat stopped (their worker died): queued again while they have
    attempts left, else failed. Each change is a compare-and-set on the lease as read (still
    running, same attempt, heartbeat still stale), so two sweepers never both requeue one run.
    Returns (requeued ids, failed ids); the head is never touched."""
    cutoff = utcnow() - timedelta(seconds=older_than)
    stale = session.execute(select(Job.id, Job.attempts).where(Job.state == "running",
                                                               Job.heartbeat_at < cutoff)).all()
    requeued, failed = [], []
    for job_id, attempts in stale:
        lease = update(Job).where(Job.id == job_id, Job.state == "running", Job.attempts == attempts,
                                  Job.heartbeat_at < cutoff)
        if attempts < max_attempts:
            changed = session.execute(lease.values(
                state="queued", stage="queued", progress=0.0, enqueued_at=utcnow(), heartbeat_at=None,
                message=f"queued again: the worker running attempt {attempts} stopped")).rowcount
            if changed:
                requeued.append(job_id)
        else:
            error = (f"the worker running this job stopped (no heartbeat for {older_than:.0f} s, "
                     f"attempt {attempts}); the project's head is unchanged")
            changed = session.execute(lease.values(
                state="failed", stage="failed", finished_at=utcnow(), error=error)).rowcount
            if changed:
                failed.append(job_id)
    session.commit()
    return requeued, failed


def queue(session: Session, submit: Callable[[int], None], project: Project, kind: str,
          user_id: int | None, params: dict[str, Any] | None = None,
          base_version_id: int | None = None) -> Job:
    """Commit a queued job, then hand its id to the queue (the sweeper resends a lost message)."""
    job = create(session, project, kind, user_id, params, base_version_id)
    session.commit()
    try:
        submit(job.id)
    except Exception:  # broker down: the row is the truth, the sweeper will resend
        log.warning("job %s: enqueue failed; the sweeper will resend it", job.id, exc_info=True)
    return job
