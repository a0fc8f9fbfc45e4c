"""REST image ids (SQL rows) <-> COLMAP image ids of a workspace, matched by file name."""

from __future__ import annotations

from typing import Any

from sqlalchemy.orm import Session

from guided_sfm.core.errors import UnknownImage
from guided_sfm.core.workspace import Workspace
from guided_sfm.db import queries


class IdMap:
    """Both directions between a project's image rows and one workspace's images."""

    def __init__(self, sql_by_name: dict[str, int], colmap_by_name: dict[str, int]) -> None:
        self.to_sql = {colmap_by_name[n]: sql_by_name[n] for n in colmap_by_name if n in sql_by_name}
        self.to_colmap = {sql: colmap for colmap, sql in self.to_sql.items()}

    @classmethod
    def load(cls, session: Session, project_id: int, workspace: Workspace) -> IdMap:
        return cls(queries.image_ids_by_name(session, project_id), workspace.image_ids())

    def colmap(self, sql_id: int) -> int:
        if sql_id not in self.to_colmap:
            raise UnknownImage(f"image {sql_id} is not part of this version's reconstruction")
        return self.to_colmap[sql_id]

    def sql(self, colmap_id: int) -> int | None:
        return self.to_sql.get(colmap_id)

    def edits_body(self, body: dict[str, Any]) -> dict[str, Any]:
        """An edit-set body with REST ids turned into this workspace's COLMAP ids."""
        cameras = [{**c, "image_id": self.colmap(c["image_id"])} for c in body.get("cameras") or []]
        pairs = [[self.colmap(a), self.colmap(b)] for a, b in body.get("delete_pairs") or []]
        return {**body, "cameras": cameras, "delete_pairs": pairs}
