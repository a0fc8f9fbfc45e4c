"""Dependencies as Annotated aliases: session, settings, store, current user, project by role, and
the image, version, edit set or job of the path (404 naming it when the caller may not see it)."""

from collections.abc import Callable, Iterator
from functools import cache
from typing import Annotated

from fastapi import Depends, Path, Request
from fastapi.security import OAuth2PasswordBearer
from sqlalchemy.orm import Session

from guided_sfm.actions import lookup
from guided_sfm.actions.lookup import InProject
from guided_sfm.api import security
from guided_sfm.db import queries
from guided_sfm.db.models import MAX_ID, EditSetRow, Image, Job, Project, User, Version
from guided_sfm.errors import Forbidden, NotFound, Unauthorized
from guided_sfm.settings import Settings
from guided_sfm.storage import ArtifactStore

PathId = Annotated[int, Path(ge=1, le=MAX_ID)]
bearer = OAuth2PasswordBearer(tokenUrl="/api/v1/auth/token", auto_error=False)


def get_session(request: Request) -> Iterator[Session]:
    with request.app.state.sessions() as session:
        yield session


def get_settings(request: Request) -> Settings:
    return request.app.state.settings


def get_store(request: Request) -> ArtifactStore:
    return request.app.state.store


def get_submit(request: Request) -> Callable[[int], None]:
    return request.app.state.submit


SessionDep = Annotated[Session, Depends(get_session)]
SettingsDep = Annotated[Settings, Depends(get_settings)]
StoreDep = Annotated[ArtifactStore, Depends(get_store)]
SubmitDep = Annotated[Callable[[int], None], Depends(get_submit)]


def current_user(session: SessionDep, settings: SettingsDep,
                 token: Annotated[str | None, Depends(bearer)]) -> User:
    if not token:
        raise Unauthorized("not authenticated: send Authorization: Bearer <token> from /api/v1/auth/token")
    user = session.get(User, security.user_id_from(token, settings.secret_key or ""))
    if user is None:
        raise Unauthorized("the token's user no longer exists")
    return user


CurrentUser = Annotated[User, Depends(current_user)]


def require_role(session: Session, user: User, project_id: int | None, needed: str,
                 missing: str | None = None) -> Project:
    """The project if the user's role is at least `needed`; no role at all looks like no such thing
    (`missing` names what was asked for: the project itself unless a job of it)."""
    role = queries.role_of(session, project_id, user.id) if project_id is not None else None
    if role is None:
        raise NotFound(f"{missing or f'project {project_id}'} not found")
    if not queries.role_at_least(role, needed):
        raise Forbidden(f"your role in project {project_id} is {role}; this needs {needed} or above")
    return session.get(Project, project_id)


@cache  # one dependency per role: FastAPI then resolves it once per request, however many ask
def project_with(needed: str) -> Callable[..., Project]:
    def dependency(pid: PathId, session: SessionDep, user: CurrentUser) -> Project:
        return require_role(session, user, pid, needed)

    return dependency


ViewerProject = Annotated[Project, Depends(project_with("viewer"))]
EditorProject = Annotated[Project, Depends(project_with("editor"))]
OwnerProject = Annotated[Project, Depends(project_with("owner"))]


def found_in_project(model: type[InProject], param: str, needed: str) -> Callable[..., InProject]:
    """The `model` row whose id is the path's `param`, in the path's project seen with role `needed`;
    404 naming both when the project has no such row (checked after the role, so nothing leaks).
    The annotations use this call's arguments, hence no `from __future__ import annotations` here."""

    def dependency(row_id: Annotated[int, Path(alias=param, ge=1, le=MAX_ID)], session: SessionDep,
                   project: Annotated[Project, Depends(project_with(needed))]) -> InProject:
        return lookup.in_project(session, model, project.id, row_id)

    return dependency


ViewerImage = Annotated[Image, Depends(found_in_project(Image, "image_id", "viewer"))]
EditorImage = Annotated[Image, Depends(found_in_project(Image, "image_id", "editor"))]
ViewerVersion = Annotated[Version, Depends(found_in_project(Version, "vid", "viewer"))]
EditorVersion = Annotated[Version, Depends(found_in_project(Version, "vid", "editor"))]
ViewerEditSet = Annotated[EditSetRow, Depends(found_in_project(EditSetRow, "eid", "viewer"))]
EditorEditSet = Annotated[EditSetRow, Depends(found_in_project(EditSetRow, "eid", "editor"))]


def job_with(needed: str) -> Callable[..., Job]:
    """The path's job if the user's role in its project is at least `needed`; jobs live outside
    projects in the path, so a stranger's 404 names the job only."""

    def dependency(job_id: PathId, session: SessionDep, user: CurrentUser) -> Job:
        job = session.get(Job, job_id)
        require_role(session, user, job.project_id if job else None, needed, f"job {job_id}")
        return job

    return dependency


ViewerJob = Annotated[Job, Depends(job_with("viewer"))]
EditorJob = Annotated[Job, Depends(job_with("editor"))]
