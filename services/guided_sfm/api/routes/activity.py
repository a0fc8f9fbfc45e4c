"""The project's activity log: newest first, paged by id, filtered by user and action."""

from typing import Annotated

from fastapi import APIRouter, Query

from guided_sfm.actions import activity
from guided_sfm.api.deps import SessionDep, ViewerProject
from guided_sfm.api.schemas import ActivityOut, ActivityPage
from guided_sfm.db.models import MAX_ID, Activity

router = APIRouter(prefix="/projects/{pid}/activity", tags=["activity"])


def out(entry: Activity) -> ActivityOut:
    return ActivityOut(id=entry.id, at=entry.at, user=entry.username, action=entry.action,
                       target=entry.target, detail=entry.detail, token=entry.token_name)


@router.get("", response_model=ActivityPage)
def list_activity(project: ViewerProject, session: SessionDep,
                  limit: Annotated[int, Query(ge=1, le=activity.MAX_PAGE)] = 50,
                  before: Annotated[int | None, Query(ge=1, le=MAX_ID)] = None,
                  user: Annotated[str | None, Query(max_length=64)] = None,
                  action: Annotated[str | None, Query(max_length=32)] = None) -> ActivityPage:
    entries, next_before = activity.page(session, project.id, limit, before, user, action)
    return ActivityPage(items=[out(e) for e in entries], next_before=next_before)
