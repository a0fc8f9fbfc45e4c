"""The worker's task run_job(job_id), a thin wrapper around actions.runner, and the sweeper thread."""

from __future__ import annotations

import PIL.Image  # noqa: F401  (before pycolmap: Pillow loaded after it crashes on PNG save)
from celery import Celery, signals
from sqlalchemy.orm import Session, sessionmaker

from guided_sfm.actions import runner
from guided_sfm.db.session import make_sessionmaker
from guided_sfm.settings import Settings
from worker.deliverer import Deliverer
from worker.sweeper import Sweeper

RUN_JOB = "guided_sfm.run_job"


def settings_of(app: Celery) -> Settings:
    return app.conf.guided_sfm_settings


def sessions_of(app: Celery) -> sessionmaker[Session]:
    """One session factory per pool process, made on first use (after the pool forked)."""
    if getattr(app, "_guided_sessions", None) is None:
        app._guided_sessions = make_sessionmaker(settings_of(app))
    return app._guided_sessions


def register(app: Celery) -> None:
    @app.task(name=RUN_JOB, bind=True, ignore_result=True)
    def run_job(self, job_id: int) -> None:
        runner.run_job(sessions_of(self.app), settings_of(self.app), int(job_id))


@signals.worker_ready.connect(dispatch_uid="guided_sfm.start_sweeper")
def start_sweeper(sender, **_kwargs) -> None:
    """Each worker's main process sweeps; a restarted worker heals what its predecessor left."""
    app = sender.app
    sweeper = Sweeper(settings_of(app), lambda job_id: app.send_task(RUN_JOB, args=[job_id]))
    app._guided_sweeper = sweeper
    sweeper.start()
    app._guided_deliverer = deliverer = Deliverer(settings_of(app))
    deliverer.start()


@signals.worker_shutdown.connect(dispatch_uid="guided_sfm.stop_sweeper")
def stop_sweeper(sender, **_kwargs) -> None:
    for name in ("_guided_sweeper", "_guided_deliverer"):
        thread = getattr(sender.app, name, None) if sender is not None else None
        if thread is not None:
            thread.stop()
