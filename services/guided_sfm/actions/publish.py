"""Turn a job's finished staging workspace into a version row, atomically, and maybe the head."""

from __future__ import annotations

import logging

from sqlalchemy.orm import Session

from guided_sfm import jobs
from guided_sfm.actions import webhooks
from guided_sfm.actions.context import NewImage, Produced
from guided_sfm.db.models import Image, Job, PairDeletion, Project, Version
from guided_sfm.errors import Conflict
from guided_sfm.storage import Store, StoreUnavailable, image_key

log = logging.getLogger(__name__)


def publish(session: Session, store: Store, job: Job, produced: Produced) -> Version:
    """Publish the workspace (one rename, or a manifest written last), insert the version, finish
    the job; all or nothing."""
    project = session.get(Project, job.project_id, with_for_update=True)
    if project is None:
        raise Conflict(f"project {job.project_id} was deleted while job {job.id} ran")
    moved = _move_images(store, job.project_id, produced)
    relative = store.publish(job.project_id, produced.workspace, produced.reuse_from)
    try:
        version = _insert(session, job, produced, relative, project)
        message = produced.message
        if project.head_version_id == job.base_version_id:
            project.head_version_id = version.id
        else:
            message += (f"; kept as a side version because the head moved from version "
                        f"{job.base_version_id} to {project.head_version_id} while the job ran")
            version.message = message
        if not jobs.finish(session, job.id, "succeeded", message=message, version_id=version.id,
                           timings=produced.timings):
            raise Conflict(f"job {job.id} was ended by someone else before it could publish")
        webhooks.version_created(session, version, project.head_version_id == version.id)
        webhooks.job_finished(session, job, "succeeded", version.id)
        session.commit()
        return version
    except BaseException:
        session.rollback()
        _clean_up(store, relative, moved)
        raise


def _clean_up(store: Store, version: str, moved: list[str]) -> None:
    """What a publish that did not commit wrote. With the store away it stays for the reconciler
    (orphans: no row names them), and the error that stopped the publish is the one raised."""
    try:
        store.discard(version)
        for key in moved:
            store.remove(key)
    except StoreUnavailable as exc:
        log.warning("files of the failed publish of %s left for the reconciler: %s", version, exc)


def _insert(session: Session, job: Job, produced: Produced, relative: str, project: Project) -> Version:
    if produced.new_images:
        _add_images(session, project.id, produced.new_images)
    version = Version(project_id=project.id, parent_id=produced.parent_id, kind=produced.kind,
                      author_id=job.created_by, message=produced.message, stats=produced.stats,
                      path=relative, edits=produced.edits)
    session.add(version)
    session.flush()
    for id1, id2, tests in produced.deleted_pairs:
        session.add(PairDeletion(version_id=version.id, image_id1=id1, image_id2=id2, tests=list(tests)))
    return version


def _add_images(session: Session, project_id: int, images: list[NewImage]) -> None:
    for seq, image in enumerate(sorted(images, key=lambda i: i.name)):
        session.add(Image(project_id=project_id, name=image.name, width=image.width,
                          height=image.height, seq=seq, taken_at=image.taken_at))
    session.flush()


def _move_images(store: Store, project_id: int, produced: Produced) -> list[str]:
    """An import's images go to the project's shared images (the project is empty); their keys."""
    if produced.images_from is None:
        return []
    moved = []
    for image in produced.new_images:
        store.put(image_key(project_id, image.name), produced.images_from / image.name)
        moved.append(image_key(project_id, image.name))
    return moved
