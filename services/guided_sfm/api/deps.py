"""Dependencies as Annotated aliases: session, settings, store, current user, project by role, and
the image, version, edit set or job of the path (404 naming it when the caller may not see it)."""

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from functools import cache
from typing import Annotated, TypeVar

from fastapi import Depends, Path, Query, Request
from fastapi.security import OAuth2PasswordBearer
from sqlalchemy.orm import Session

from guided_sfm.actions import lookup, tokens
from guided_sfm.actions.activity import Actor
from guided_sfm.actions.lookup import InProject
from guided_sfm.api import security
from guided_sfm.api.throttle import Throttle
from guided_sfm.db import queries
from guided_sfm.db.models import MAX_ID, AccessToken, EditSetRow, Image, Job, Project, User, Version
from guided_sfm.db.session import read_only
from guided_sfm.errors import Forbidden, NotFound, Unauthorized
from guided_sfm.settings import Settings
from guided_sfm.storage import Store

PathId = Annotated[int, Path(ge=1, le=MAX_ID)]
MAX_PAGE = 10_000
T = TypeVar("T")
bearer = OAuth2PasswordBearer(tokenUrl="/api/v1/auth/token", auto_error=False)


READ_METHODS = ("GET", "HEAD", "OPTIONS")


def get_session(request: Request) -> Iterator[Session]:
    """A session per request; reads do not take SQLite's write lock (see db.session)."""
    with request.app.state.sessions() as session:
        if request.method in READ_METHODS or getattr(request.state, "reads_only", False):
            read_only(session)
        yield session


def get_settings(request: Request) -> Settings:
    return request.app.state.settings


def get_store(request: Request) -> Store:
    return request.app.state.store


def get_submit(request: Request) -> Callable[[int], None]:
    return request.app.state.submit


def get_throttle(request: Request) -> Throttle:
    return request.app.state.throttle


def client_address(request: Request) -> str:
    return request.app.state.throttle.client(request)


SessionDep = Annotated[Session, Depends(get_session)]
ThrottleDep = Annotated[Throttle, Depends(get_throttle)]
ClientAddress = Annotated[str, Depends(client_address)]
SettingsDep = Annotated[Settings, Depends(get_settings)]
StoreDep = Annotated[Store, Depends(get_store)]
SubmitDep = Annotated[Callable[[int], None], Depends(get_submit)]


def current_user(request: Request, session: SessionDep, settings: SettingsDep,
                 token: Annotated[str | None, Depends(bearer)]) -> User:
    """The caller, from a session token or a personal access token; the latter is kept on
    `request.state.token` so that its scope and projects limit what follows."""
    if not token:
        raise Unauthorized("not authenticated: send Authorization: Bearer <token> from /api/v1/auth/token")
    request.state.token = None
    if tokens.is_personal(token):
        request.state.token = access = tokens.resolve(session, token)
        tokens.allows(access, request.method)
        return access.user
    user_id, epoch = security.session_claims(token, settings.secret_key or "")
    user = session.get(User, user_id)
    if user is None:
        raise Unauthorized("the token's user no longer exists")
    if epoch != user.token_epoch:
        raise Unauthorized("the password changed since this token was issued; sign in again")
    return user


CurrentUser = Annotated[User, Depends(current_user)]


def personal_token(request: Request) -> AccessToken | None:
    return getattr(request.state, "token", None)


def session_only(request: Request, user: CurrentUser) -> User:
    """The caller, when signed in with a password session: a token cannot mint tokens or change
    the password (a leaked token must not outlive its revocation)."""
    if personal_token(request) is not None:
        raise Forbidden("this needs a password session, not an access token")
    return user


SessionUser = Annotated[User, Depends(session_only)]


def require_role(session: Session, user: User, project_id: int | None, needed: str,
                 missing: str | None = None, token: AccessToken | None = None) -> Project:
    """The project if the user's role is at least `needed`; no role at all, or a project the access
    `token` is not for, looks like no such thing (`missing` names what was asked for: the project
    itself unless a job of it)."""
    role = queries.role_of(session, project_id, user.id) if project_id is not None else None
    if token is not None and token.projects is not None and project_id not in token.projects:
        role = None
    if role is None:
        raise NotFound(f"{missing or f'project {project_id}'} not found")
    if not queries.role_at_least(role, needed):
        raise Forbidden(f"your role in project {project_id} is {role}; this needs {needed} or above")
    return session.get(Project, project_id)


@cache  # one dependency per role: FastAPI then resolves it once per request, however many ask
def project_with(needed: str) -> Callable[..., Project]:
    def dependency(request: Request, pid: PathId, session: SessionDep, user: CurrentUser) -> Project:
        return require_role(session, user, pid, needed, token=personal_token(request))

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

    def dependency(request: Request, job_id: PathId, session: SessionDep, user: CurrentUser) -> Job:
        job = session.get(Job, job_id)
        require_role(session, user, job.project_id if job else None, needed, f"job {job_id}",
                     personal_token(request))
        return job

    return dependency


ViewerJob = Annotated[Job, Depends(job_with("viewer"))]


@dataclass(frozen=True)
class Page:
    """Opt-in paging of a list (design.md): without `limit` the whole list, as in v1."""

    limit: int | None
    offset: int

    def of(self, items: Sequence[T]) -> list[T]:
        end = None if self.limit is None else self.offset + self.limit
        return list(items[self.offset:end])


def page(limit: Annotated[int | None, Query(ge=1, le=MAX_PAGE)] = None,
         offset: Annotated[int, Query(ge=0, le=MAX_ID)] = 0) -> Page:
    return Page(limit, offset)


PageDep = Annotated[Page, Depends(page)]
EditorJob = Annotated[Job, Depends(job_with("editor"))]


def actor(request: Request, user: CurrentUser) -> Actor:
    """The caller as the activity log names them (with the access token's name, if one was used)."""
    token = personal_token(request)
    return Actor.of(user, token.name if token is not None else None)


ActorDep = Annotated[Actor, Depends(actor)]
