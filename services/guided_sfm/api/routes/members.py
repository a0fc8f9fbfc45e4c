"""Project members and their roles (owners only change them; the last owner stays)."""

from fastapi import APIRouter, Response

from guided_sfm.actions import members
from guided_sfm.actions.activity import record
from guided_sfm.api.deps import ActorDep, OwnerProject, SessionDep, ViewerProject
from guided_sfm.api.schemas import MemberIn, MemberOut
from guided_sfm.db import queries

router = APIRouter(prefix="/projects/{pid}/members", tags=["members"])


@router.get("", response_model=list[MemberOut])
def list_members(project: ViewerProject, session: SessionDep) -> list[MemberOut]:
    return [MemberOut(username=m.user.username, role=m.role) for m in queries.members(session, project.id)]


@router.put("/{username}", response_model=MemberOut)
def set_member(username: str, body: MemberIn, project: OwnerProject, session: SessionDep,
               actor: ActorDep) -> MemberOut:
    membership = members.set_role(session, project, username, body.role)
    record(session, project.id, actor, "member", {"kind": "member", "username": username},
           {"username": username, "role": body.role})
    return MemberOut(username=username, role=membership.role)


@router.delete("/{username}", status_code=204)
def remove_member(username: str, project: OwnerProject, session: SessionDep, actor: ActorDep) -> Response:
    members.remove(session, project, username)
    record(session, project.id, actor, "member", {"kind": "member", "username": username},
           {"username": username, "role": None})
    return Response(status_code=204)
