"""Edit sets: drafts of camera moves and pair deletions on a base version; preview and apply."""

from typing import Annotated

from fastapi import APIRouter, Header, Response

from guided_sfm.actions import edit_sets, rebase, version_data
from guided_sfm.api.deps import (
    CurrentUser,
    EditorEditSet,
    EditorProject,
    SessionDep,
    StoreDep,
    SubmitDep,
    ViewerEditSet,
    ViewerProject,
)
from guided_sfm.api.schemas import ApplyIn, EditSetIn, EditSetOut, JobOut, PreviewOut, RebaseOut
from guided_sfm.db import queries
from guided_sfm.db.models import EditSetRow, Job, Version

router = APIRouter(prefix="/projects/{pid}/edits", tags=["edits"])


def out(row: EditSetRow, response: Response | None = None,
        applied: dict[tuple[int, int], int] | None = None) -> EditSetOut:
    if response is not None:
        response.headers["ETag"] = f'"{row.revision}"'
    return EditSetOut(id=row.id, revision=row.revision, updated_at=row.updated_at,
                      updated_by=row.updated_by.username if row.updated_by else None,
                      applied_version_id=(applied or {}).get((row.id, row.revision)),
                      **{k: v for k, v in row.body.items() if k in EditSetIn.model_fields})


@router.post("", status_code=201, response_model=EditSetOut)
def create(body: EditSetIn, project: EditorProject, session: SessionDep, user: CurrentUser,
           response: Response) -> EditSetOut:
    return out(edit_sets.create(session, project, body.model_dump(), user.id), response)


@router.get("", response_model=list[EditSetOut])
def list_edit_sets(project: ViewerProject, session: SessionDep) -> list[EditSetOut]:
    applied = queries.applied_revisions(session, project.id)
    return [out(row, applied=applied) for row in queries.edit_sets(session, project.id)]


@router.get("/{eid}", response_model=EditSetOut)
def read(row: ViewerEditSet, session: SessionDep, response: Response) -> EditSetOut:
    return out(row, response, queries.applied_revisions(session, row.project_id))


@router.put("/{eid}", response_model=EditSetOut)
def replace(row: EditorEditSet, body: EditSetIn, project: EditorProject, session: SessionDep,
            user: CurrentUser, response: Response,
            if_match: Annotated[str | None, Header()] = None) -> EditSetOut:
    return out(edit_sets.replace(session, project, row, body.model_dump(), if_match, user.id), response)


@router.delete("/{eid}", status_code=204)
def delete(row: EditorEditSet, session: SessionDep) -> Response:
    edit_sets.delete(session, row)
    return Response(status_code=204)


@router.get("/{eid}/preview", response_model=PreviewOut)
def preview(row: ViewerEditSet, session: SessionDep, store: StoreDep) -> dict:
    return version_data.preview(session, store, row, session.get(Version, row.base_version_id))


@router.post("/{eid}/apply", status_code=202, response_model=JobOut)
def apply(row: EditorEditSet, project: EditorProject, session: SessionDep, user: CurrentUser,
          submit: SubmitDep, body: ApplyIn | None = None) -> Job:
    return edit_sets.apply(session, submit, project, row, user.id, (body or ApplyIn()).remap)


@router.post("/{eid}/rebase", response_model=RebaseOut)
def rebase_onto_head(row: EditorEditSet, project: EditorProject, session: SessionDep, user: CurrentUser,
                     store: StoreDep, response: Response,
                     if_match: Annotated[str | None, Header()] = None) -> RebaseOut:
    """Carry the edit set onto the head (If-Match: its revision); the report says what was kept."""
    row, report = rebase.rebase(session, store, project, row, if_match, user.id)
    return RebaseOut(**out(row, response).model_dump(), report=report)
