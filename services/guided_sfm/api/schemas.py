"""Pydantic request (…In/…Create) and response (…Out) models of the REST contract v1."""

from __future__ import annotations

import dataclasses
from datetime import datetime
from typing import Annotated, Any, Literal, get_type_hints

from pydantic import AfterValidator, BaseModel, ConfigDict, Field, StrictInt, create_model

from guided_sfm.core.types import DEFAULT_RULE, RULES, CameraEdit
from guided_sfm.db.models import MAX_ID

Role = Literal["viewer", "editor", "owner"]


def _storable(text: str) -> str:
    if "\x00" in text:
        raise ValueError("must not contain NUL characters")
    return text


Text = Annotated[str, AfterValidator(_storable)]  # Postgres text cannot hold NUL
DbId = Annotated[StrictInt, Field(ge=1, le=MAX_ID)]  # an id the SQL integer columns can hold


class Out(BaseModel):
    model_config = ConfigDict(from_attributes=True)


class In(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


class UserCreate(In):
    username: str = Field(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9_.@-]+$")
    password: Text = Field(min_length=8, max_length=256)


class UserOut(Out):
    id: int
    username: str


class TokenOut(Out):
    access_token: str
    token_type: str = "bearer"


class ProjectCreate(In):
    name: Text = Field(min_length=1, max_length=200)
    description: Text = Field(default="", max_length=10_000)


class ProjectOut(Out):
    id: int
    name: str
    description: str
    head_version_id: int | None
    created_at: datetime
    role: Role | None = None
    owner: str | None = None  # the first owner's username, for the project list


class MemberIn(In):
    role: Role


class MemberOut(Out):
    username: str
    role: Role


class ImageOut(Out):
    id: int
    name: str
    width: int
    height: int
    seq: int


class ReconstructIn(In):
    camera_model: str | None = None
    matcher: Literal["exhaustive", "sequential"] | None = None
    mapper: Literal["incremental", "global"] | None = None


class JobOut(Out):
    id: int
    project_id: int
    kind: str
    state: str
    stage: str
    progress: float
    message: str
    error: str | None
    version_id: int | None
    base_version_id: int | None
    cancel_requested: bool
    created_at: datetime
    started_at: datetime | None
    finished_at: datetime | None
    timings: dict[str, Any] | None = None  # seconds and peak memory (MiB) per stage, once ended


class StatsOut(Out):
    num_images: int = 0
    num_registered: int = 0
    num_models: int = 0
    num_pairs: int = 0
    num_points: int = 0


class VersionOut(Out):
    id: int
    parent_id: int | None
    kind: str
    author: str | None
    message: str
    created_at: datetime
    stats: StatsOut
    is_head: bool = False


class PairOut(Out):
    image_id1: int
    image_id2: int
    num_inliers: int


def _shape_of(value_type: type, name: str, **overrides: Any) -> type[In]:
    """A request model with the fields of a core value type (a dataclass), some types overridden."""
    hints = get_type_hints(value_type)
    fields = {f.name: (overrides.get(f.name, hints[f.name]),
                       ... if f.default is dataclasses.MISSING else f.default)
              for f in dataclasses.fields(value_type)}
    return create_model(name, __base__=In, **fields)


# Edit sets: the models give the body's shape (types, for OpenAPI); what the values mean (fov and
# range bounds, known images, the rule, tolerance names) is checked by core.edits.parse_edits when
# actions.edit_sets saves the body, so a bad value answers 422 naming the field and nothing is stored.
CameraEditIn = _shape_of(CameraEdit, "CameraEditIn", image_id=DbId)


class EditSetIn(In):
    base_version_id: DbId
    cameras: list[CameraEditIn] = Field(default_factory=list)
    delete_pairs: list[tuple[DbId, DbId]] = Field(default_factory=list)
    flags: list[DbId] = Field(default_factory=list)
    rule: str = Field(default=DEFAULT_RULE, json_schema_extra={"enum": list(RULES)})
    tolerances: dict[Text, float] = Field(default_factory=dict)


class EditSetOut(Out):
    id: int
    revision: int
    base_version_id: int
    cameras: list[dict[str, Any]]
    delete_pairs: list[list[int]]
    flags: list[int]
    rule: str
    tolerances: dict[str, float]
    updated_by: str | None
    updated_at: datetime
    applied_version_id: int | None = None  # the version an apply of this revision made, if any


class RebaseOut(EditSetOut):
    """The edit set on the head and what was carried onto it; `dropped` items are {kind: camera |
    flag | delete_pair, image_ids, reason}."""

    report: dict[str, Any]


class ReasonOut(Out):
    pair: list[int]
    tests: list[str]


class PreviewOut(Out):
    pairs_to_delete: list[list[int]]
    components_before: int
    components_after: int
    removed_by_test: dict[str, int]
    kept_to_connect: list[list[int]]
    reasons: list[ReasonOut]


class ApplyIn(In):
    remap: bool = True


class CompareCameraOut(Out):
    image_id: int | None
    moved: float | None = None
    rotated_deg: float | None = None


class CompareOut(Out):
    cameras: list[CompareCameraOut]
