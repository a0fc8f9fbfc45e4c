"""Find a row of a project by id, or refuse as if it did not exist (one 404 for every route)."""

from __future__ import annotations

from typing import TypeVar

from sqlalchemy.orm import Session

from guided_sfm.db.models import Comment, EditSetRow, Image, Version
from guided_sfm.errors import NotFound

NOUNS = {Image: "image", Version: "version", EditSetRow: "edit set", Comment: "comment"}  # in 404 messages
InProject = TypeVar("InProject", Image, Version, EditSetRow, Comment)


def in_project(session: Session, model: type[InProject], project_id: int, row_id: int) -> InProject:
    """The project's row of `model` with this id; NotFound naming both when there is none."""
    row = session.get(model, row_id)
    if row is None or row.project_id != project_id:
        raise NotFound(f"{NOUNS[model]} {row_id} not found in project {project_id}")
    return row
