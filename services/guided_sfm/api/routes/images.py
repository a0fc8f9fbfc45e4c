"""Images: upload (JPEG/PNG or one zip of them), list, thumbnail, original file, delete."""

from typing import Annotated

from fastapi import APIRouter, File, Response, UploadFile
from fastapi.responses import FileResponse

from guided_sfm.actions import images as image_actions
from guided_sfm.actions.activity import record
from guided_sfm.api.blobs import blob_response
from guided_sfm.api.deps import (
    ActorDep,
    EditorImage,
    EditorProject,
    PageDep,
    SessionDep,
    SettingsDep,
    StoreDep,
    ViewerImage,
    ViewerProject,
)
from guided_sfm.api.schemas import ImageOut
from guided_sfm.db import queries
from guided_sfm.db.models import Image

router = APIRouter(prefix="/projects/{pid}/images", tags=["images"])


@router.post("", status_code=201, response_model=list[ImageOut])
def upload_images(project: EditorProject, session: SessionDep, store: StoreDep, settings: SettingsDep,
                  files: Annotated[list[UploadFile], File(description="JPEG/PNG files or one .zip")],
                  actor: ActorDep) -> list[Image]:
    uploads = [(f.filename or "", f.file) for f in files]
    rows = image_actions.upload(session, store, project, uploads, settings.max_upload_bytes,
                                settings.max_image_mpx)
    record(session, project.id, actor, "upload", {"kind": "project"},
           {"count": len(rows), "image_ids": [row.id for row in rows]})
    return rows


@router.get("", response_model=list[ImageOut])
def list_images(project: ViewerProject, session: SessionDep, page: PageDep) -> list[Image]:
    return page.of(queries.images(session, project.id))


@router.get("/{image_id}/thumbnail", response_class=FileResponse)
def thumbnail(image: ViewerImage, store: StoreDep) -> Response:
    return blob_response(image_actions.thumbnail(store, image), media_type="image/jpeg")


@router.get("/{image_id}/file", response_class=FileResponse)
def original(image: ViewerImage, store: StoreDep) -> Response:
    return blob_response(image_actions.original(store, image), filename=image.name)


@router.delete("/{image_id}", status_code=204)
def delete_image(image: EditorImage, session: SessionDep, store: StoreDep) -> Response:
    """204 when no version uses the image, else 409 naming the versions (design.md v1.1)."""
    image_actions.delete(session, store, image)
    return Response(status_code=204)
