"""Images: upload (JPEG/PNG or one zip of them), list, thumbnail, original file."""

from typing import Annotated

from fastapi import APIRouter, File, UploadFile
from fastapi.responses import FileResponse

from guided_sfm.actions import images as image_actions
from guided_sfm.api.deps import EditorProject, PathId, SessionDep, SettingsDep, StoreDep, ViewerProject
from guided_sfm.api.schemas import ImageOut
from guided_sfm.db import queries
from guided_sfm.db.models import Image, Project
from guided_sfm.errors import NotFound

router = APIRouter(prefix="/projects/{pid}/images", tags=["images"])


@router.post("", status_code=201, response_model=list[ImageOut])
def upload_images(project: EditorProject, session: SessionDep, store: StoreDep, settings: SettingsDep,
                  files: Annotated[list[UploadFile], File(description="JPEG/PNG files or one .zip")]
                  ) -> list[Image]:
    uploads = [(f.filename or "", f.file) for f in files]
    return image_actions.upload(session, store, project, uploads, settings.max_upload_bytes)


@router.get("", response_model=list[ImageOut])
def list_images(project: ViewerProject, session: SessionDep) -> list[Image]:
    return queries.images(session, project.id)


def _image(session: SessionDep, project: Project, image_id: PathId) -> Image:
    image = queries.image_in_project(session, project.id, image_id)
    if image is None:
        raise NotFound(f"image {image_id} not found in project {project.id}")
    return image


@router.get("/{image_id}/thumbnail", response_class=FileResponse)
def thumbnail(image_id: PathId, project: ViewerProject, session: SessionDep, store: StoreDep) -> FileResponse:
    path = image_actions.thumbnail(store, _image(session, project, image_id))
    return FileResponse(path, media_type="image/jpeg")


@router.get("/{image_id}/file", response_class=FileResponse)
def original(image_id: PathId, project: ViewerProject, session: SessionDep, store: StoreDep) -> FileResponse:
    image = _image(session, project, image_id)
    return FileResponse(store.image_file(project.id, image.name), filename=image.name)
