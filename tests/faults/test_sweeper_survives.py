"""The sweeper thread survives broker errors of any type (kombu's are not OSError): it logs, backs
off and resends once the broker is back."""

from __future__ import annotations

import time
from datetime import timedelta

from kombu.exceptions import OperationalError as BrokerDown

from guided_sfm.db.models import Job, Project, utcnow
from guided_sfm.db.session import make_sessionmaker
from tests.conftest import make_settings
from worker.sweeper import Sweeper


def test_sweeper_keeps_going_through_a_broker_outage(tmp_path, committed_database):
    settings = make_settings(tmp_path / "data", committed_database, sweep_seconds=0.05, requeue_seconds=0.0)
    sessions = make_sessionmaker(settings)
    with sessions() as session:
        project = Project(name="p")
        session.add(project)
        session.flush()
        session.add(Job(project_id=project.id, kind="reconstruct", state="queued", params={},
                        enqueued_at=utcnow() - timedelta(hours=1)))
        session.commit()
    sent, broker_up = [], []

    def submit(job_id: int) -> None:
        if not broker_up:
            raise BrokerDown("Error 111 connecting to 127.0.0.1:6379. Connection refused.")
        sent.append(job_id)

    sweeper = Sweeper(settings, submit)
    sweeper.start()
    try:
        time.sleep(0.5)
        assert sweeper.is_alive() and sweeper.failures >= 2
        broker_up.append(True)
        deadline = time.monotonic() + 5
        while not sent and time.monotonic() < deadline:
            time.sleep(0.05)
        assert sent and sweeper.is_alive()
    finally:
        sweeper.stop()
        sweeper.join(timeout=10)
    sessions.kw["bind"].dispose()
