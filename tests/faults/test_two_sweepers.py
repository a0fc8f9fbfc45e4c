"""Two sweepers and a stalled job: one requeues it, a worker claims the new attempt, and the other
sweeper, acting on what it read before, must not requeue that live run (never two runs at once).
On SQLite sweepers cannot interleave (each write transaction holds the file's lock from its start),
so the race exists on Postgres only."""

from __future__ import annotations

from datetime import timedelta

import pytest
from sqlalchemy import event

from guided_sfm import jobs
from guided_sfm.db.models import Job, Project, utcnow
from guided_sfm.db.session import make_engine, make_sessionmaker


def test_a_late_sweeper_leaves_a_reclaimed_job_alone(committed_database):
    if committed_database.startswith("sqlite"):
        pytest.skip("SQLite serializes write transactions: the interleaving cannot happen")
    first, second = make_engine(committed_database), make_engine(committed_database)
    sessions_a, sessions_b = make_sessionmaker(first), make_sessionmaker(second)
    with sessions_a() as session:
        project = Project(name="p")
        session.add(project)
        session.flush()
        job = Job(project_id=project.id, kind="reconstruct", state="running", params={}, attempts=1,
                  heartbeat_at=utcnow() - timedelta(hours=1))
        session.add(job)
        session.commit()
        job_id = job.id
    interleaved = []

    def meanwhile(_conn, _cursor, statement, *_args) -> None:
        """Right after sweeper B read the stale jobs: sweeper A requeues, a worker claims again."""
        if statement.lstrip().startswith("SELECT") and "heartbeat_at" in statement and not interleaved:
            interleaved.append(True)
            with sessions_a() as session:
                assert jobs.recover_stale(session, 60)[0] == [job_id]
                assert jobs.claim(session, job_id)

    event.listen(second, "after_cursor_execute", meanwhile)
    with sessions_b() as session:
        requeued, failed = jobs.recover_stale(session, 60)
    assert interleaved and requeued == [] and failed == []
    with sessions_a() as session:
        job = session.get(Job, job_id)
        assert (job.state, job.attempts) == ("running", 2)
    first.dispose()
    second.dispose()
