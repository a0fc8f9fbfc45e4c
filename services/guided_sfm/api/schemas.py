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


class ProblemOut(BaseModel):
    loc: list[str | int]
    msg: str


class InvalidOut(BaseModel):
    """A 422 as api/errors.py writes it: one sentence, and the problems when validation found them."""

    detail: str
    errors: list[ProblemOut] = Field(default_factory=list)


class UserCreate(In):
    username: str = Field(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9_.@-]+$")
    password: Text = Field(min_length=8, max_length=256)


class UserOut(Out):
    id: int
    username: str


class TokenOut(Out):
    access_token: str
    token_type: str = "bearer"


class PasswordChange(In):
    old_password: Text = Field(max_length=256)
    new_password: Text = Field(min_length=8, max_length=256)


class AccessTokenCreate(In):
    name: Text = Field(min_length=1, max_length=100)
    scope: Literal["read", "write"]
    projects: list[DbId] | None = Field(default=None, max_length=1000)  # None: every project
    expires_days: int | None = Field(default=None, ge=1, le=3650)  # None: until revoked


class AccessTokenOut(Out):
    id: int
    name: str
    scope: str
    projects: list[int] | None
    created_at: datetime
    expires_at: datetime | None


class AccessTokenCreated(AccessTokenOut):
    token: str  # the secret, shown this once


class WebhookIn(In):
    url: Text = Field(min_length=1, max_length=2000)
    events: list[Literal["job_finished", "version_created", "edit_submitted", "edit_reviewed"]] = Field(
        min_length=1)
    secret: Text | None = Field(default=None, min_length=16, max_length=200)  # None: one is generated


class WebhookOut(Out):
    id: int
    url: str
    events: list[str]
    created_at: datetime


class WebhookCreated(WebhookOut):
    secret: str  # shown this once; each delivery's X-Guided-SFM-Signature is an HMAC with it


class DeliveryOut(Out):
    id: int
    event: str
    at: datetime
    status_code: int | None
    attempts: int
    ok: bool = False
    state: str  # pending (retries left), ok, failed (given up)
    answer: str | None


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
    require_approval: bool = False
    published_version_id: int | None = None  # the team's accepted result


class ProjectPatch(In):
    name: Text | None = Field(default=None, min_length=1, max_length=200)
    description: Text | None = Field(default=None, max_length=10_000)
    require_approval: bool | None = None


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
    sha256: str | None = None  # of the file (null for images stored before it was kept)
    already_uploaded: bool = False  # an upload sent again: this name with this content was there


MIN_IMAGE_SIZE, MAX_IMAGE_SIZE = 256, 10_000


def _image_size(size: int) -> int:
    if 0 < size < MIN_IMAGE_SIZE:
        raise ValueError(f"must be 0 (COLMAP's own, 3200) or from {MIN_IMAGE_SIZE} to {MAX_IMAGE_SIZE}")
    return size


# SIFT's longest side in pixels; 0: COLMAP's own (3200); None: the product's (sfm.DEFAULT_MAX_IMAGE_SIZE)
ImageSize = Annotated[StrictInt, Field(ge=0, le=MAX_IMAGE_SIZE), AfterValidator(_image_size)]


class ReconstructIn(In):
    camera_model: str | None = None
    matcher: Literal["auto", "exhaustive", "sequential", "retrieval"] | None = None  # None: auto
    mapper: Literal["incremental", "global", "hierarchical"] | None = None
    max_image_size: ImageSize | None = None


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
    queue_position: int | None = None  # while queued: 1 = next to run (applies go first)


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


class ReviewOut(Out):
    id: int
    reviewer: str | None
    verdict: str
    comment: str
    revision: int
    created_at: datetime
    review_state: str | None = None  # the edit set's state after this review (in the POST answer)


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
    author: str | None = None
    review_state: str = "draft"
    reviews: list[ReviewOut] = Field(default_factory=list)


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
    message: Text | None = Field(default=None, max_length=2000)  # the version's note, in the author's words


class CompareCameraOut(Out):
    image_id: int | None
    moved: float | None = None
    rotated_deg: float | None = None


class CompareOut(Out):
    cameras: list[CompareCameraOut]


# Triage (design.md, contract additions v1.1)
class SuspectOut(Out):
    image_id: int
    score: float
    reasons: list[str]


class ProposalCameraOut(Out):
    image_id: int
    x: float
    y: float
    yaw_deg: float


class ProposalOut(Out):
    cameras: list[ProposalCameraOut]


class RunOut(Out):
    image_ids: list[int]
    reason: str
    proposal: ProposalOut | None


class SuspectsOut(Out):
    suspects: list[SuspectOut]
    runs: list[RunOut]


# Team review (design.md, contract additions v1.1)
class ActivityOut(Out):
    id: int
    at: datetime
    user: str | None
    action: str
    target: dict[str, Any]
    detail: dict[str, Any]
    token: str | None = None  # the personal access token's name, when the change came through one


class ActivityPage(Out):
    items: list[ActivityOut]
    next_before: int | None


class ReviewIn(In):
    verdict: Literal["approve", "request_changes"]
    comment: Text = Field(default="", max_length=10_000)


CommentKind = Literal["image", "pair", "version", "edit_set", "project"]


class CommentTarget(In):
    kind: CommentKind
    id: DbId | None = None  # image, version or edit set id
    image_ids: list[DbId] | None = Field(default=None, min_length=2, max_length=2)  # a pair


class CommentIn(In):
    target: CommentTarget
    body: Text = Field(min_length=1, max_length=10_000)  # plain text, shown as text
    parent_id: DbId | None = None


class CommentPatch(In):
    body: Text | None = Field(default=None, min_length=1, max_length=10_000)
    resolved: bool | None = None


class CommentOut(Out):
    id: int
    author: str | None
    created_at: datetime
    updated_at: datetime
    body: str
    target: dict[str, Any]
    parent_id: int | None
    resolved: bool


class PresenceIn(In):
    edit_set_id: DbId | None = None
    version_id: DbId | None = None


class PresenceOut(Out):
    username: str
    edit_set_id: int | None
    version_id: int | None
    seen_at: datetime


class NotificationOut(Out):
    id: int
    at: datetime
    kind: str
    project_id: int
    target: dict[str, Any]
    text: str
    read: bool


class NotificationsRead(In):
    ids: list[DbId] = Field(max_length=1000)
