"""Edit sets: drafts of camera moves and pair deletions on a base version; preview and apply."""

from typing import Annotated

from fastapi import APIRouter, Header, Response

from guided_sfm.actions import edit_sets, rebase, review, version_data
from guided_sfm.actions.activity import record
from guided_sfm.api.deps import (
    ActorDep,
    CurrentUser,
    EditorEditSet,
    EditorProject,
    SessionDep,
    StoreDep,
    SubmitDep,
    ViewerEditSet,
    ViewerProject,
)
from guided_sfm.api.routes.jobs import job_out
from guided_sfm.api.schemas import (
    ApplyIn,
    EditSetIn,
    EditSetOut,
    JobOut,
    PreviewOut,
    RebaseOut,
    ReviewIn,
    ReviewOut,
)
from guided_sfm.db import queries
from guided_sfm.db.models import EditSetRow, Review, Version

router = APIRouter(prefix="/projects/{pid}/edits", tags=["edits"])


def out(row: EditSetRow, response: Response | None = None,
        applied: dict[tuple[int, int], int] | None = None) -> EditSetOut:
    if response is not None:
        response.headers["ETag"] = f'"{row.revision}"'
    return EditSetOut(id=row.id, revision=row.revision, updated_at=row.updated_at,
                      updated_by=row.updated_by.username if row.updated_by else None,
                      applied_version_id=(applied or {}).get((row.id, row.revision)),
                      author=row.created_by.username if row.created_by else None,
                      review_state=row.review_state, reviews=[review_out(r) for r in row.reviews],
                      **{k: v for k, v in row.body.items() if k in EditSetIn.model_fields})


def review_out(entry: Review, state: str | None = None) -> ReviewOut:
    return ReviewOut(id=entry.id, reviewer=entry.reviewer.username if entry.reviewer else None,
                     verdict=entry.verdict, comment=entry.comment, revision=entry.revision,
                     created_at=entry.created_at, review_state=state)


def saved(session: SessionDep, row: EditSetRow, actor: ActorDep) -> None:
    record(session, row.project_id, actor, "edit_save", {"kind": "edit_set", "id": row.id},
           {"revision": row.revision})


@router.post("", status_code=201, response_model=EditSetOut)
def create(body: EditSetIn, project: EditorProject, session: SessionDep, user: CurrentUser,
           response: Response, actor: ActorDep) -> EditSetOut:
    row = edit_sets.create(session, project, body.model_dump(), user.id)
    saved(session, row, actor)
    return out(row, response)


@router.get("", response_model=list[EditSetOut])
def list_edit_sets(project: ViewerProject, session: SessionDep) -> list[EditSetOut]:
    applied = queries.applied_revisions(session, project.id)
    return [out(row, applied=applied) for row in queries.edit_sets(session, project.id)]


@router.get("/{eid}", response_model=EditSetOut)
def read(row: ViewerEditSet, session: SessionDep, response: Response) -> EditSetOut:
    return out(row, response, queries.applied_revisions(session, row.project_id))


@router.put("/{eid}", response_model=EditSetOut)
def replace(row: EditorEditSet, body: EditSetIn, project: EditorProject, session: SessionDep,
            user: CurrentUser, response: Response, actor: ActorDep,
            if_match: Annotated[str | None, Header()] = None) -> EditSetOut:
    row = edit_sets.replace(session, project, row, body.model_dump(), if_match, user.id)
    saved(session, row, actor)
    return out(row, response)


@router.delete("/{eid}", status_code=204)
def delete(row: EditorEditSet, session: SessionDep, actor: ActorDep) -> Response:
    project_id, edit_set_id, revision = row.project_id, row.id, row.revision
    edit_sets.delete(session, row)
    record(session, project_id, actor, "edit_delete", {"kind": "edit_set", "id": edit_set_id},
           {"revision": revision})
    return Response(status_code=204)


@router.get("/{eid}/preview", response_model=PreviewOut)
def preview(row: ViewerEditSet, session: SessionDep, store: StoreDep) -> dict:
    return version_data.preview(session, store, row, session.get(Version, row.base_version_id))


@router.post("/{eid}/apply", status_code=202, response_model=JobOut)
def apply(row: EditorEditSet, project: EditorProject, session: SessionDep, user: CurrentUser,
          submit: SubmitDep, actor: ActorDep, body: ApplyIn | None = None) -> JobOut:
    body = body or ApplyIn()
    review.check_apply(project, row)
    job = edit_sets.apply(session, submit, project, row, user.id, body.remap, body.message)
    record(session, project.id, actor, "apply", {"kind": "edit_set", "id": row.id},
           {"job_id": job.id, "revision": row.revision, "message": body.message})
    return job_out(session, job)


@router.post("/{eid}/submit", response_model=EditSetOut)
def submit_for_review(row: EditorEditSet, project: EditorProject, session: SessionDep,
                      actor: ActorDep, response: Response) -> EditSetOut:
    return out(review.submit(session, project, row, actor), response)


@router.post("/{eid}/reviews", status_code=201, response_model=ReviewOut)
def add_review(row: EditorEditSet, project: EditorProject, session: SessionDep, actor: ActorDep,
               body: ReviewIn) -> ReviewOut:
    entry = review.review(session, project, row, actor, body.verdict, body.comment)
    return review_out(entry, row.review_state)


@router.post("/{eid}/rebase", response_model=RebaseOut)
def rebase_onto_head(row: EditorEditSet, project: EditorProject, session: SessionDep, user: CurrentUser,
                     store: StoreDep, response: Response, actor: ActorDep,
                     if_match: Annotated[str | None, Header()] = None) -> RebaseOut:
    """Carry the edit set onto the head (If-Match: its revision); the report says what was kept."""
    before = row.revision
    row, report = rebase.rebase(session, store, project, row, if_match, user.id)
    if row.revision != before:
        saved(session, row, actor)
    return RebaseOut(**out(row, response).model_dump(), report=report)
