"""Versions: list, scene, pairs, suspects, restore, export, compare."""

import functools
import gzip
from pathlib import PurePosixPath
from typing import Annotated, Any, Literal

from fastapi import APIRouter, Query, Request, Response
from fastapi.responses import FileResponse
from starlette.background import BackgroundTask

from guided_sfm.actions import export as export_action
from guided_sfm.actions import lookup, project_settings, version_data
from guided_sfm.actions import restore as restore_action
from guided_sfm.actions.activity import record
from guided_sfm.api.compression import accepts_gzip
from guided_sfm.api.deps import (
    ActorDep,
    CurrentUser,
    EditorProject,
    EditorVersion,
    PageDep,
    SessionDep,
    StoreDep,
    ViewerProject,
    ViewerVersion,
)
from guided_sfm.api.schemas import CompareOut, PairOut, ProjectOut, SuspectsOut, VersionOut
from guided_sfm.db import queries
from guided_sfm.db.models import MAX_ID, Version

router = APIRouter(prefix="/projects/{pid}/versions", tags=["versions"])


def out(version: Version, head_id: int | None) -> VersionOut:
    return VersionOut(id=version.id, parent_id=version.parent_id, kind=version.kind,
                      author=version.author.username if version.author else None,
                      message=version.message, created_at=version.created_at,
                      stats=version.stats or {}, is_head=version.id == head_id)


@router.get("", response_model=list[VersionOut])
def list_versions(project: ViewerProject, session: SessionDep) -> list[VersionOut]:
    return [out(v, project.head_version_id) for v in queries.versions(session, project.id)]


@router.get("/{vid}/scene", response_model=dict[str, Any])
def scene(version: ViewerVersion, session: SessionDep, store: StoreDep, request: Request) -> Response:
    """The top-down scene: a version never changes, so it is cached, tagged (304 when the client
    has it) and sent gzipped to clients that take it."""
    tag = f'"scene-{version.id}-{PurePosixPath(version.path).name}"'
    headers = {"ETag": tag, "Cache-Control": "private, max-age=0, must-revalidate", "Vary": "Accept-Encoding"}
    if tag in request.headers.get("if-none-match", ""):
        return Response(status_code=304, headers=headers)
    data = version_data.scene_json(session, store, version)
    if accepts_gzip(request):
        return Response(_gzipped(data), media_type="application/json",
                        headers={**headers, "Content-Encoding": "gzip"})
    return Response(data, media_type="application/json", headers=headers)


@functools.lru_cache(maxsize=32)
def _gzipped(data: bytes) -> bytes:
    """The cached scene's bytes are the same object each time, so their hash is computed once."""
    return gzip.compress(data, compresslevel=6, mtime=0)


@router.get("/{vid}/pairs", response_model=list[PairOut])
def pairs(version: ViewerVersion, session: SessionDep, store: StoreDep, page: PageDep,
          image_id: Annotated[int | None, Query(ge=1, le=MAX_ID)] = None) -> list[dict]:
    return page.of(version_data.pairs(session, store, version, image_id))


@router.get("/{vid}/suspects", response_model=SuspectsOut)
def suspects(version: ViewerVersion, session: SessionDep, store: StoreDep) -> dict:
    """Cameras likely misplaced (score in [0, 1], raised from 0.5), with reasons, and runs that
    move as one with a proposal of where each belongs (design.md v1.1, Triage)."""
    return version_data.suspects(session, store, version)


@router.post("/{vid}/restore", status_code=201, response_model=VersionOut)
def restore(version: EditorVersion, project: EditorProject, session: SessionDep, store: StoreDep,
            user: CurrentUser, actor: ActorDep) -> VersionOut:
    restored = restore_action.restore(session, store, project, version, user.id)
    record(session, project.id, actor, "restore", {"kind": "version", "id": restored.id},
           {"from_version_id": version.id})
    return out(restored, project.head_version_id)


@router.post("/{vid}/publish", response_model=ProjectOut)
def publish(version: EditorVersion, project: EditorProject, session: SessionDep, user: CurrentUser,
            actor: ActorDep) -> ProjectOut:
    """The version becomes the project's published result (`published_version_id`)."""
    published = project_settings.publish(session, project, version, actor)
    return ProjectOut.model_validate(published).model_copy(
        update={"role": queries.role_of(session, project.id, user.id),
                "owner": queries.owner_name(session, project.id)})


@router.get("/{vid}/export", response_class=FileResponse)
def export(version: ViewerVersion, store: StoreDep,
           format: Annotated[Literal["colmap", "ply", "colmap_text", "nerfstudio"], Query()] = "colmap"
           ) -> FileResponse:
    path, name, media_type = export_action.export(store, version, format)
    return FileResponse(path, media_type=media_type, filename=name,
                        background=BackgroundTask(path.unlink, missing_ok=True))


@router.get("/{vid}/compare", response_model=CompareOut)
def compare(version: ViewerVersion, session: SessionDep, store: StoreDep,
            to: Annotated[int, Query(ge=1, le=MAX_ID, description="the other version's id")]) -> dict:
    other = lookup.in_project(session, Version, version.project_id, to)
    return version_data.compare(session, store, version, other)
