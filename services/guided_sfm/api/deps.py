"""Dependencies as Annotated aliases: session, settings, store, current user, project by role."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Annotated

from fastapi import Depends, Path, Request
from fastapi.security import OAuth2PasswordBearer
from sqlalchemy.orm import Session

from guided_sfm.api import security
from guided_sfm.db import queries
from guided_sfm.db.models import MAX_ID, Job, Project, User, Version
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


def require_role(session: Session, user: User, project_id: int, needed: str) -> Project:
    """The project if the user's role is at least `needed`; no role at all looks like no project."""
    project = session.get(Project, project_id)
    role = queries.role_of(session, project_id, user.id) if project is not None else None
    if role is None:
        raise NotFound(f"project {project_id} not found")
    if not queries.role_at_least(role, needed):
        raise Forbidden(f"your role in project {project_id} is {role}; this needs {needed} or above")
    return project


def project_with(needed: str) -> Callable[..., Project]:
    def dependency(pid: PathId, session: SessionDep, user: CurrentUser) -> Project:
        return require_role(session, user, pid, needed)

    return dependency


ViewerProject = Annotated[Project, Depends(project_with("viewer"))]
EditorProject = Annotated[Project, Depends(project_with("editor"))]
OwnerProject = Annotated[Project, Depends(project_with("owner"))]


def project_version(vid: PathId, project: ViewerProject, session: SessionDep) -> Version:
    version = queries.version_in_project(session, project.id, vid)
    if version is None:
        raise NotFound(f"version {vid} not found in project {project.id}")
    return version


ProjectVersion = Annotated[Version, Depends(project_version)]


def job_with(needed: str) -> Callable[..., Job]:
    def dependency(job_id: PathId, session: SessionDep, user: CurrentUser) -> Job:
        job = session.get(Job, job_id)
        if job is None:
            raise NotFound(f"job {job_id} not found")
        try:
            require_role(session, user, job.project_id, needed)
        except NotFound as exc:
            raise NotFound(f"job {job_id} not found") from exc
        return job

    return dependency


ViewerJob = Annotated[Job, Depends(job_with("viewer"))]
EditorJob = Annotated[Job, Depends(job_with("editor"))]
