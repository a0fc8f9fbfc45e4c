"""Comments on an image, a pair, a version, an edit set or the project: replies, @mentions of
members (each notified once), resolve and reopen. Bodies are plain text, stored as given."""

from __future__ import annotations

import re
from typing import Any

from sqlalchemy import or_, select
from sqlalchemy.orm import Session

from guided_sfm.actions import lookup, notifications
from guided_sfm.actions.activity import Actor, record
from guided_sfm.core.errors import InvalidInput
from guided_sfm.db import queries
from guided_sfm.db.models import Comment, EditSetRow, Image, Project, Version, utcnow
from guided_sfm.errors import Forbidden

# "@name" not inside a word or an e-mail address; names may hold . @ - as usernames do
MENTION = re.compile(r"(?<![\w@.])@([A-Za-z0-9_][A-Za-z0-9_.@-]*)")
KEY_OF = {"image": "image_id", "version": "version_id", "edit_set": "edit_set_id"}
MODEL_OF = {"image": Image, "version": Version, "edit_set": EditSetRow}


def mentioned(session: Session, project_id: int, body: str) -> dict[int, str]:
    """The members an @name in the body names ({user_id: username}); InvalidInput naming the first
    @name that is no member (a trailing '.' or '-' ends a sentence, not a name)."""
    members = {m.user.username: m.user_id for m in queries.members(session, project_id)}
    found: dict[int, str] = {}
    for raw in MENTION.findall(body):
        name = next((n for n in (raw, raw.rstrip(".-@")) if n in members), None)
        if name is None:
            raise InvalidInput(f"@{raw.rstrip('.-@')} is not a member of project {project_id}; "
                               "only members can be mentioned")
        found[members[name]] = name
    return found


def target_of(comment: Comment) -> dict[str, Any]:
    if comment.target_kind == "pair":
        return {"kind": "pair", "image_ids": [comment.image_id, comment.image_id2]}
    key = KEY_OF.get(comment.target_kind)
    return {"kind": comment.target_kind, **({"id": getattr(comment, key)} if key else {})}


def _columns(session: Session, project_id: int, target: dict[str, Any]) -> dict[str, Any]:
    """The comment's target columns, checked against the project (404 for a thing not in it)."""
    kind, target_id, image_ids = target["kind"], target.get("id"), target.get("image_ids")
    if kind == "pair":
        if target_id is not None or not image_ids or len(set(image_ids)) != 2 or len(image_ids) != 2:
            raise InvalidInput("a pair's target is image_ids: [id1, id2] (two different images), no id")
        first, second = sorted(image_ids)
        for image_id in (first, second):
            lookup.in_project(session, Image, project_id, image_id)
        return {"target_kind": kind, "image_id": first, "image_id2": second}
    if image_ids is not None:
        raise InvalidInput(f"a {kind} target takes no image_ids")
    if kind == "project":
        if target_id is not None:
            raise InvalidInput("the project target takes no id")
        return {"target_kind": kind}
    if target_id is None:
        raise InvalidInput(f"a {kind} target needs its id")
    lookup.in_project(session, MODEL_OF[kind], project_id, target_id)
    return {"target_kind": kind, KEY_OF[kind]: target_id}


def post(session: Session, project: Project, actor: Actor, target: dict[str, Any], body: str,
         parent_id: int | None = None) -> Comment:
    """A new comment (or a reply, on its parent's target); mentioned members are notified."""
    _check_body(body)
    columns = _columns(session, project.id, target)
    if parent_id is not None:
        parent = lookup.in_project(session, Comment, project.id, parent_id)
        if target_of(parent) != target_of(Comment(**columns)):
            raise InvalidInput(f"a reply's target is its parent's: {target_of(parent)}")
    people = mentioned(session, project.id, body)
    comment = Comment(project_id=project.id, author_id=actor.user_id, parent_id=parent_id, body=body,
                      resolved=False, **columns)
    session.add(comment)
    session.flush()
    _notify(session, comment, actor, set(people))
    detail = {"comment_id": comment.id, "parent_id": parent_id, "op": "post",
              "mentions": sorted(people.values())}
    record(session, project.id, actor, "comment", target_of(comment), detail, commit=False)
    session.commit()
    return comment


def change(session: Session, project: Project, comment: Comment, actor: Actor, role: str,
           body: str | None, resolved: bool | None) -> Comment:
    """Edit the body (its author only; new mentions are notified) and/or resolve or reopen it (its
    author, or an editor or owner)."""
    mine = comment.author_id is not None and comment.author_id == actor.user_id
    if body is not None and not mine:
        raise Forbidden(f"only the author of comment {comment.id} may edit its body")
    if resolved is not None and not (mine or queries.role_at_least(role, "editor")):
        raise Forbidden(f"your role in project {project.id} is {role}; resolving another's comment "
                        "needs editor or above")
    ops = []
    if body is not None and body != comment.body:
        _check_body(body)
        before = names_in(comment.body)
        people = mentioned(session, project.id, body)
        comment.body = body
        _notify(session, comment, actor, {uid for uid, name in people.items() if name not in before})
        ops.append("edit")
    if resolved is not None and resolved != comment.resolved:
        comment.resolved = resolved
        ops.append("resolve" if resolved else "reopen")
    if ops:
        comment.updated_at = utcnow()
        record(session, project.id, actor, "comment", target_of(comment),
               {"comment_id": comment.id, "op": "+".join(ops)}, commit=False)
    session.commit()
    return comment


def delete(session: Session, project: Project, comment: Comment, actor: Actor, role: str) -> None:
    """Its author or an owner deletes a comment (and its replies)."""
    if comment.author_id != actor.user_id and role != "owner":
        raise Forbidden(f"only the author of comment {comment.id} or an owner may delete it; "
                        f"your role in project {project.id} is {role}")
    record(session, project.id, actor, "comment", target_of(comment),
           {"comment_id": comment.id, "op": "delete"}, commit=False)
    session.delete(comment)
    session.commit()


def listed(session: Session, project_id: int, kind: str | None, target_id: int | None,
           resolved: bool | None) -> list[Comment]:
    """Oldest first; `target_id` picks the thing (for pairs: either image)."""
    query = select(Comment).where(Comment.project_id == project_id)
    if kind is not None:
        query = query.where(Comment.target_kind == kind)
    if target_id is not None:
        query = query.where(or_(*(key == target_id for key in _keys(kind))))
    if resolved is not None:
        query = query.where(Comment.resolved.is_(resolved))
    return list(session.scalars(query.order_by(Comment.id)))


def names_in(body: str) -> set[str]:
    """Every @name of a body, as written and without a sentence's trailing punctuation."""
    return {name for raw in MENTION.findall(body) for name in (raw, raw.rstrip(".-@"))}


def _keys(kind: str | None) -> list[Any]:
    """The columns an id filter looks at: a pair's two images, one kind's key, or any key."""
    if kind == "pair":
        return [Comment.image_id, Comment.image_id2]
    if kind in KEY_OF:
        return [getattr(Comment, KEY_OF[kind])]
    return [Comment.image_id, Comment.image_id2, Comment.version_id, Comment.edit_set_id]


def _check_body(body: str) -> None:
    if not body.strip():
        raise InvalidInput("a comment needs a body (plain text)")


def _notify(session: Session, comment: Comment, actor: Actor, user_ids: set[int]) -> None:
    author = actor.username or "someone"
    text = f"{author} mentioned you: {comment.body[:200]}"
    target = {"kind": "comment", "id": comment.id, "on": target_of(comment)}
    notifications.notify(session, user_ids - {actor.user_id}, comment.project_id, "mention", target, text)

