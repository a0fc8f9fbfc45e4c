"""Comments: post (any member, viewers included), list, edit or resolve, delete."""

from typing import Annotated

from fastapi import APIRouter, Depends, Query, Response

from guided_sfm.actions import comments
from guided_sfm.api.deps import ActorDep, CurrentUser, SessionDep, ViewerProject, found_in_project
from guided_sfm.api.schemas import CommentIn, CommentKind, CommentOut, CommentPatch
from guided_sfm.db import queries
from guided_sfm.db.models import MAX_ID, Comment

router = APIRouter(prefix="/projects/{pid}/comments", tags=["comments"])
ViewerComment = Annotated[Comment, Depends(found_in_project(Comment, "cid", "viewer"))]


def out(comment: Comment) -> CommentOut:
    return CommentOut(id=comment.id, author=comment.author.username if comment.author else None,
                      created_at=comment.created_at, updated_at=comment.updated_at, body=comment.body,
                      target=comments.target_of(comment), parent_id=comment.parent_id,
                      resolved=comment.resolved)


@router.post("", status_code=201, response_model=CommentOut)
def post_comment(body: CommentIn, project: ViewerProject, session: SessionDep, actor: ActorDep) -> CommentOut:
    target = body.target.model_dump(exclude_none=True)
    return out(comments.post(session, project, actor, target, body.body, body.parent_id))


@router.get("", response_model=list[CommentOut])
def list_comments(project: ViewerProject, session: SessionDep,
                  kind: Annotated[CommentKind | None, Query()] = None,
                  id: Annotated[int | None, Query(ge=1, le=MAX_ID)] = None,
                  resolved: Annotated[bool | None, Query()] = None) -> list[CommentOut]:
    """Oldest first, replies included; `id` picks the target (either image of a pair)."""
    return [out(c) for c in comments.listed(session, project.id, kind, id, resolved)]


@router.patch("/{cid}", response_model=CommentOut)
def change_comment(comment: ViewerComment, body: CommentPatch, project: ViewerProject, session: SessionDep,
                   user: CurrentUser, actor: ActorDep) -> CommentOut:
    role = queries.role_of(session, project.id, user.id)
    return out(comments.change(session, project, comment, actor, role, body.body, body.resolved))


@router.delete("/{cid}", status_code=204)
def delete_comment(comment: ViewerComment, project: ViewerProject, session: SessionDep, user: CurrentUser,
                   actor: ActorDep) -> Response:
    comments.delete(session, project, comment, actor, queries.role_of(session, project.id, user.id))
    return Response(status_code=204)
