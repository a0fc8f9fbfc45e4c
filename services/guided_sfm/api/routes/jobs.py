"""Jobs: start a reconstruction or an import, list, read, cancel."""

from typing import Annotated

from fastapi import APIRouter, File, UploadFile

from guided_sfm import jobs
from guided_sfm.actions import import_workspace, uploads
from guided_sfm.api.deps import (
    CurrentUser,
    EditorJob,
    EditorProject,
    SessionDep,
    SettingsDep,
    StoreDep,
    SubmitDep,
    ViewerJob,
    ViewerProject,
)
from guided_sfm.api.schemas import JobOut, ReconstructIn
from guided_sfm.core.sfm import SfmOptions
from guided_sfm.db import queries
from guided_sfm.db.models import Job
from guided_sfm.errors import Conflict

router = APIRouter(tags=["jobs"])


@router.post("/projects/{pid}/reconstruct", status_code=202, response_model=JobOut)
def reconstruct(project: EditorProject, session: SessionDep, user: CurrentUser, submit: SubmitDep,
                body: ReconstructIn | None = None) -> Job:
    params = (body or ReconstructIn()).model_dump(exclude_none=True)
    SfmOptions(**params)  # unknown camera models are refused here, not in the worker
    return jobs.queue(session, submit, project, "reconstruct", user.id, params, project.head_version_id)


@router.post("/projects/{pid}/import", status_code=202, response_model=JobOut)
def import_(project: EditorProject, session: SessionDep, user: CurrentUser, submit: SubmitDep,
            store: StoreDep, settings: SettingsDep,
            file: Annotated[UploadFile, File(description="zip of database.db, sparse/0/, images/")]) -> Job:
    if not queries.is_empty(session, project.id):
        raise Conflict(f"project {project.id} already has images or versions; import needs an empty project")
    if queries.active_job(session, project.id) is not None:
        raise Conflict(f"project {project.id} already has a queued or running job")
    folder = store.project_dir(project.id) / "uploads"
    folder.mkdir(parents=True, exist_ok=True)
    with store.staging(project.id, prefix="import-") as staging:
        staged = staging / "workspace.zip"
        uploads.copy_limited(file.file, staged, uploads.Budget(settings.max_upload_bytes), "file")
        import_workspace.check_archive(staged, settings.max_upload_bytes)
        kept = folder / f"{staging.name}.zip"
        staged.replace(kept)
    try:
        params = {"upload": str(kept.relative_to(store.root))}
        return jobs.queue(session, submit, project, "import", user.id, params, None)
    except BaseException:
        kept.unlink(missing_ok=True)
        raise


@router.get("/projects/{pid}/jobs", response_model=list[JobOut])
def list_jobs(project: ViewerProject, session: SessionDep) -> list[Job]:
    return queries.jobs(session, project.id)


@router.get("/jobs/{job_id}", response_model=JobOut)
def get_job(job: ViewerJob) -> Job:
    return job


@router.post("/jobs/{job_id}/cancel", response_model=JobOut)
def cancel_job(job: EditorJob, session: SessionDep) -> Job:
    jobs.request_cancel(session, job)
    return job
