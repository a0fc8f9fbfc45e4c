"""Jobs: start a reconstruction or an import, list, read, cancel."""

from typing import Annotated

from fastapi import APIRouter, File, UploadFile

from guided_sfm import jobs
from guided_sfm.actions import import_workspace
from guided_sfm.actions import reconstruct as reconstruct_action
from guided_sfm.actions.activity import job_ended, record
from guided_sfm.api.deps import (
    ActorDep,
    CurrentUser,
    EditorJob,
    EditorProject,
    PageDep,
    SessionDep,
    SettingsDep,
    StoreDep,
    SubmitDep,
    ViewerJob,
    ViewerProject,
)
from guided_sfm.api.schemas import JobOut, ReconstructIn
from guided_sfm.db import queries
from guided_sfm.db.models import Job

router = APIRouter(tags=["jobs"])


def jobs_out(session: SessionDep, rows: list[Job]) -> list[JobOut]:
    """The jobs with their place in the queue (one query for the whole list)."""
    positions = jobs.queue_positions(session) if any(j.state == "queued" for j in rows) else {}
    return [JobOut.model_validate(j).model_copy(update={"queue_position": positions.get(j.id)})
            for j in rows]


def job_out(session: SessionDep, job: Job) -> JobOut:
    return jobs_out(session, [job])[0]


@router.post("/projects/{pid}/reconstruct", status_code=202, response_model=JobOut)
def reconstruct(project: EditorProject, session: SessionDep, user: CurrentUser, submit: SubmitDep,
                actor: ActorDep, body: ReconstructIn | None = None) -> JobOut:
    params = (body or ReconstructIn()).model_dump(exclude_none=True)
    job = reconstruct_action.queue(session, submit, project, user.id, params)
    record(session, project.id, actor, "reconstruct", {"kind": "job", "id": job.id},
           {"job_id": job.id, **params})
    return job_out(session, job)


@router.post("/projects/{pid}/import", status_code=202, response_model=JobOut)
def import_(project: EditorProject, session: SessionDep, user: CurrentUser, submit: SubmitDep,
            store: StoreDep, settings: SettingsDep, actor: ActorDep,
            file: Annotated[UploadFile, File(description="zip of database.db, sparse/0/, images/")],
            ) -> JobOut:
    job = import_workspace.queue(session, store, submit, project, user.id, file.file,
                                 settings.max_upload_bytes)
    record(session, project.id, actor, "import", {"kind": "job", "id": job.id}, {"job_id": job.id})
    return job_out(session, job)


@router.get("/projects/{pid}/jobs", response_model=list[JobOut])
def list_jobs(project: ViewerProject, session: SessionDep, page: PageDep) -> list[JobOut]:
    return jobs_out(session, page.of(queries.jobs(session, project.id)))


@router.get("/jobs/{job_id}", response_model=JobOut)
def get_job(job: ViewerJob, session: SessionDep) -> JobOut:
    return job_out(session, job)


@router.post("/jobs/{job_id}/cancel", response_model=JobOut)
def cancel_job(job: EditorJob, session: SessionDep) -> Job:
    jobs.request_cancel(session, job)
    job_ended(session, job.id)  # a queued job ends at once (a running one when its worker sees the flag)
    return job
