"""Projects: create, list (those with a role), read, delete (owner, not while a job runs)."""

from fastapi import APIRouter, Request, Response

from guided_sfm.actions import project_settings, projects
from guided_sfm.api.deps import (
    ActorDep,
    CurrentUser,
    OwnerProject,
    SessionDep,
    StoreDep,
    ViewerProject,
    personal_token,
)
from guided_sfm.api.schemas import ProjectCreate, ProjectOut, ProjectPatch
from guided_sfm.db import queries
from guided_sfm.db.models import Project
from guided_sfm.errors import Forbidden

router = APIRouter(prefix="/projects", tags=["projects"])


def out(session: SessionDep, project: Project, user_id: int) -> ProjectOut:
    """The project with the caller's role and its owner's name."""
    extra = {"role": queries.role_of(session, project.id, user_id),
             "owner": queries.owner_name(session, project.id)}
    return ProjectOut.model_validate(project).model_copy(update=extra)


@router.post("", status_code=201, response_model=ProjectOut)
def create_project(body: ProjectCreate, request: Request, session: SessionDep, store: StoreDep,
                   user: CurrentUser) -> ProjectOut:
    token = personal_token(request)
    if token is not None and token.projects is not None:
        raise Forbidden(f"the access token {token.name!r} is limited to projects {token.projects}")
    return out(session, projects.create(session, store, user.id, body.name, body.description), user.id)


@router.get("", response_model=list[ProjectOut])
def list_projects(request: Request, session: SessionDep, user: CurrentUser) -> list[ProjectOut]:
    """The projects you have a role in (those an access token is limited to, if it is)."""
    token = personal_token(request)
    return [out(session, p, user.id) for p in queries.projects_of(session, user.id)
            if token is None or token.projects is None or p.id in token.projects]


@router.get("/{pid}", response_model=ProjectOut)
def get_project(project: ViewerProject, session: SessionDep, user: CurrentUser) -> ProjectOut:
    return out(session, project, user.id)


@router.patch("/{pid}", response_model=ProjectOut)
def change_settings(body: ProjectPatch, project: OwnerProject, session: SessionDep,
                    actor: ActorDep) -> ProjectOut:
    """Owners change the name, description and `require_approval` (apply then waits for approval)."""
    changed = project_settings.change(session, project, body.model_dump(exclude_unset=True), actor)
    return out(session, changed, actor.user_id)


@router.delete("/{pid}", status_code=204)
def delete_project(project: OwnerProject, session: SessionDep, store: StoreDep) -> Response:
    projects.delete(session, store, project)
    return Response(status_code=204)
