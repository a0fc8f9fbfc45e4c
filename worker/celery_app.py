"""make_celery(settings): the Celery app on Redis or the filesystem broker; submit(app, job_id)."""

from __future__ import annotations

from collections.abc import Callable
from functools import partial

from celery import Celery

from guided_sfm.settings import Settings
from worker import tasks


def make_celery(settings: Settings) -> Celery:
    app = Celery("guided_sfm", set_as_current=False)
    app.conf.update(
        broker_url=settings.broker_url,
        broker_connection_retry_on_startup=True,
        task_serializer="json",
        accept_content=["json"],
        task_ignore_result=True,  # the job row is the truth, not a result backend
        task_acks_late=True,
        worker_prefetch_multiplier=1,  # a long job must not hold other jobs' messages
        worker_concurrency=1,  # one SfM job per worker process; pycolmap uses the threads
        worker_hijack_root_logger=False,
        task_create_missing_queues=True,
    )
    if settings.broker_url.startswith("filesystem"):
        _filesystem_broker(app, settings)
    app.conf.guided_sfm_settings = settings
    tasks.register(app)
    return app


def _filesystem_broker(app: Celery, settings: Settings) -> None:
    """One folder is both ends of the queue for the API, the worker and beat on this machine."""
    queue, processed = settings.broker_dir / "queue", settings.broker_dir / "processed"
    control = settings.broker_dir / "control"  # kombu's default is ./control in the cwd
    for folder in (queue, processed, control):
        folder.mkdir(parents=True, exist_ok=True)
    app.conf.update(
        broker_url="filesystem://",
        broker_transport_options={"data_folder_in": str(queue), "data_folder_out": str(queue),
                                  "processed_folder": str(processed), "store_processed": False,
                                  "control_folder": str(control),
                                  "polling_interval": 0.2},  # the default 1 s caps it at 1 message/s
        worker_enable_remote_control=False,  # the filesystem transport has no broadcast
        worker_send_task_events=False,
    )


def submit(app: Celery, job_id: int) -> None:
    """Enqueue a committed job by id; the worker re-reads the row."""
    app.send_task(tasks.RUN_JOB, args=[job_id])


def submitter(app: Celery) -> Callable[[int], None]:
    return partial(submit, app)
