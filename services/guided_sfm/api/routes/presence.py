"""Presence (any member reports where they are; the editor polls) and the caller's notifications."""

from typing import Annotated

from fastapi import APIRouter, Depends, Query, Request

from guided_sfm.actions import notifications, presence
from guided_sfm.api.deps import CurrentUser, SessionDep, ViewerProject, personal_token
from guided_sfm.api.schemas import NotificationOut, NotificationsRead, PresenceIn, PresenceOut
from guided_sfm.db.models import Notification

router = APIRouter(tags=["presence"])


def reads_only(request: Request) -> None:
    """The request's session only reads: presence writes its row in a short transaction of its
    own (on SQLite a request-long write lock would queue every member's report behind the others)."""
    request.state.reads_only = True


@router.post("/projects/{pid}/presence", response_model=list[PresenceOut], dependencies=[Depends(reads_only)])
def report_presence(request: Request, project: ViewerProject, session: SessionDep, user: CurrentUser,
                    body: PresenceIn | None = None) -> list[PresenceOut]:
    """Say where you are; answers everyone seen in the last 30 s, you included."""
    body = body or PresenceIn()
    rows = presence.report(session, request.app.state.sessions, project.id, user.id, body.edit_set_id,
                           body.version_id)
    return [PresenceOut(username=r.user.username, edit_set_id=r.edit_set_id, version_id=r.version_id,
                        seen_at=r.seen_at) for r in rows]


def token_projects(request: Request) -> list[int] | None:
    token = personal_token(request)
    return token.projects if token is not None else None


@router.get("/notifications", response_model=list[NotificationOut], tags=["notifications"])
def list_notifications(request: Request, session: SessionDep, user: CurrentUser,
                       unread: Annotated[bool, Query()] = False) -> list[Notification]:
    """Your notifications, newest first (those of an access token's projects, if it is limited)."""
    return notifications.of_user(session, user.id, unread, token_projects(request))


@router.post("/notifications/read", tags=["notifications"])
def mark_read(body: NotificationsRead, request: Request, session: SessionDep,
              user: CurrentUser) -> dict[str, int]:
    """Mark your notifications read; ids that are not yours are skipped."""
    return {"read": notifications.mark_read(session, user.id, body.ids, token_projects(request))}
