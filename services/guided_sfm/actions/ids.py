"""REST image ids (SQL rows) <-> COLMAP image ids of a workspace, matched by file name.

The one policy for a workspace image without an SQL row (no REST id): every REST answer leaves it
out; `pairs`, `pairs_with` and `rows` below are where that happens."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any, TypeVar

from sqlalchemy.orm import Session

from guided_sfm.core.errors import UnknownImage
from guided_sfm.core.workspace import Workspace
from guided_sfm.db import queries

Pair = tuple[int, int]
T = TypeVar("T")


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

    def pairs_with(self, items: Iterable[tuple[Pair, T]]) -> list[tuple[Pair, T]]:
        """(COLMAP pair, value) -> (REST pair as (smaller, larger), value), in the given order; pairs
        with an image SQL does not know are left out."""
        rest = [((self.to_sql.get(a), self.to_sql.get(b)), value) for (a, b), value in items]
        return [((min(a, b), max(a, b)), value) for (a, b), value in rest if a is not None and b is not None]

    def pairs(self, pairs: Iterable[Pair]) -> list[list[int]]:
        """COLMAP pairs as sorted [smaller, larger] REST pairs; unknown images left out."""
        return sorted(list(pair) for pair, _ in self.pairs_with((pair, None) for pair in pairs))

    def rows(self, rows: Iterable[dict[str, Any]]) -> list[dict[str, Any]]:
        """Rows keyed by a COLMAP `image_id`, in REST ids; rows of unknown images left out."""
        return [{**row, "image_id": self.to_sql[row["image_id"]]} for row in rows
                if row["image_id"] in self.to_sql]

    def edits_body(self, body: dict[str, Any]) -> dict[str, Any]:
        """An edit-set body with REST ids turned into this workspace's COLMAP ids."""
        cameras = [{**c, "image_id": self.colmap(c["image_id"])} for c in body.get("cameras") or []]
        pairs = [[self.colmap(a), self.colmap(b)] for a, b in body.get("delete_pairs") or []]
        return {**body, "cameras": cameras, "delete_pairs": pairs}
