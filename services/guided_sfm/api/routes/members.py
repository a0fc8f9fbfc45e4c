"""Project members and their roles (owners only change them; the last owner stays)."""

from fastapi import APIRouter, Response

from guided_sfm.api.deps import OwnerProject, SessionDep, ViewerProject
from guided_sfm.api.schemas import MemberIn, MemberOut
from guided_sfm.db import queries
from guided_sfm.db.models import Membership, Project
from guided_sfm.errors import Conflict, NotFound

router = APIRouter(prefix="/projects/{pid}/members", tags=["members"])


@router.get("", response_model=list[MemberOut])
def list_members(project: ViewerProject, session: SessionDep) -> list[MemberOut]:
    return [MemberOut(username=m.user.username, role=m.role) for m in queries.members(session, project.id)]


def _user_id(session: SessionDep, username: str) -> int:
    user = queries.user_by_name(session, username)
    if user is None:
        raise NotFound(f"no user named {username!r}")
    return user.id


def _keep_an_owner(session: SessionDep, project: Project, membership: Membership | None) -> None:
    last_owner = membership is not None and membership.role == "owner"
    if last_owner and queries.owner_count(session, project.id) == 1:
        raise Conflict(f"{membership.user.username!r} is the last owner of project {project.id}")


@router.put("/{username}", response_model=MemberOut)
def set_member(username: str, body: MemberIn, project: OwnerProject, session: SessionDep) -> MemberOut:
    user_id = _user_id(session, username)
    membership = session.get(Membership, (project.id, user_id))
    if body.role != "owner":
        _keep_an_owner(session, project, membership)
    if membership is None:
        membership = Membership(project_id=project.id, user_id=user_id, role=body.role)
        session.add(membership)
    membership.role = body.role
    session.commit()
    return MemberOut(username=username, role=body.role)


@router.delete("/{username}", status_code=204)
def remove_member(username: str, project: OwnerProject, session: SessionDep) -> Response:
    membership = session.get(Membership, (project.id, _user_id(session, username)))
    if membership is None:
        raise NotFound(f"{username!r} is not a member of project {project.id}")
    _keep_an_owner(session, project, membership)
    session.delete(membership)
    session.commit()
    return Response(status_code=204)
