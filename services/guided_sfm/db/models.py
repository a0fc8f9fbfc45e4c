"""SQLAlchemy 2 models of the service; no business logic (that lives in jobs.py and actions/)."""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Any

from sqlalchemy import (
    JSON,
    Boolean,
    DateTime,
    Float,
    ForeignKey,
    Index,
    Integer,
    String,
    Text,
    TypeDecorator,
    UniqueConstraint,
    text,
)
from sqlalchemy.orm import Mapped, mapped_column, relationship

from guided_sfm.db.base import Base

ROLES = ("viewer", "editor", "owner")
TOKEN_SCOPES = ("read", "write")
WEBHOOK_EVENTS = ("job_finished", "version_created", "edit_submitted", "edit_reviewed")
JOB_KINDS = ("reconstruct", "apply", "import")
JOB_STATES = ("queued", "running", "succeeded", "failed", "cancelled")
ACTIVE_STATES = ("queued", "running")
ACTIVE_SQL = "state IN ('queued', 'running')"
VERSION_KINDS = ("reconstruct", "apply", "import", "restore")
REVIEW_STATES = ("draft", "in_review", "approved", "changes_requested")
ACTIVITY_ACTIONS = ("upload", "reconstruct", "import", "edit_save", "edit_delete", "submit", "review",
                    "apply", "restore", "publish", "member", "comment", "settings", "job_end")
NOTIFICATION_KINDS = ("mention", "review_requested", "reviewed", "job_finished")
MAX_ID = 2**31 - 1  # ids are SQL INTEGER columns: a larger value would overflow the database driver


def utcnow() -> datetime:
    return datetime.now(UTC)


class Timestamp(TypeDecorator):
    """UTC timestamps that read back timezone-aware on SQLite too (it stores them naive)."""

    impl = DateTime(timezone=True)
    cache_ok = True

    def process_bind_param(self, value: datetime | None, dialect: Any) -> datetime | None:
        if value is not None and value.tzinfo is not None:
            value = value.astimezone(UTC)
        return value if value is None or dialect.name != "sqlite" else value.replace(tzinfo=None)

    def process_result_value(self, value: datetime | None, dialect: Any) -> datetime | None:
        return value.replace(tzinfo=UTC) if value is not None and value.tzinfo is None else value


class User(Base):
    __tablename__ = "users"

    id: Mapped[int] = mapped_column(primary_key=True)
    username: Mapped[str] = mapped_column(String(64), unique=True)
    password_hash: Mapped[str] = mapped_column(String(255))
    # Session tokens carry the epoch they were issued in; a password change moves it on.
    token_epoch: Mapped[int] = mapped_column(Integer, default=0, server_default="0")
    created_at: Mapped[datetime] = mapped_column(Timestamp(), default=utcnow)


class AccessToken(Base):
    """A personal access token: only its SHA-256 digest is kept (the secret is shown once)."""

    __tablename__ = "access_tokens"

    id: Mapped[int] = mapped_column(primary_key=True)
    user_id: Mapped[int] = mapped_column(ForeignKey("users.id", ondelete="CASCADE"), index=True)
    name: Mapped[str] = mapped_column(String(100))
    scope: Mapped[str] = mapped_column(String(8))  # read | write
    projects: Mapped[list[int] | None] = mapped_column(JSON)  # None: every project of the user
    digest: Mapped[str] = mapped_column(String(64), unique=True)
    created_at: Mapped[datetime] = mapped_column(Timestamp(), default=utcnow)
    expires_at: Mapped[datetime | None] = mapped_column(Timestamp())

    user: Mapped[User] = relationship(lazy="joined")


class Project(Base):
    __tablename__ = "projects"

    id: Mapped[int] = mapped_column(primary_key=True)
    name: Mapped[str] = mapped_column(String(200))
    description: Mapped[str] = mapped_column(Text, default="")
    created_by: Mapped[int | None] = mapped_column(ForeignKey("users.id", ondelete="SET NULL"))
    head_version_id: Mapped[int | None] = mapped_column(
        ForeignKey("versions.id", ondelete="SET NULL", use_alter=True)
    )
    created_at: Mapped[datetime] = mapped_column(Timestamp(), default=utcnow)
    # Team review (v1.1): apply waits for an approval when set; the team's accepted result.
    require_approval: Mapped[bool] = mapped_column(Boolean, default=False, server_default=text("false"))
    published_version_id: Mapped[int | None] = mapped_column(
        ForeignKey("versions.id", ondelete="SET NULL", use_alter=True)
    )


class Membership(Base):
    __tablename__ = "memberships"

    project_id: Mapped[int] = mapped_column(ForeignKey("projects.id", ondelete="CASCADE"), primary_key=True)
    user_id: Mapped[int] = mapped_column(ForeignKey("users.id", ondelete="CASCADE"), primary_key=True)
    role: Mapped[str] = mapped_column(String(16))

    user: Mapped[User] = relationship(lazy="joined")


class Image(Base):
    __tablename__ = "images"
    __table_args__ = (UniqueConstraint("project_id", "name", name="uq_images_project_id_name"),)

    id: Mapped[int] = mapped_column(primary_key=True)
    project_id: Mapped[int] = mapped_column(ForeignKey("projects.id", ondelete="CASCADE"), index=True)
    name: Mapped[str] = mapped_column(String(255))
    width: Mapped[int] = mapped_column(Integer)
    height: Mapped[int] = mapped_column(Integer)
    seq: Mapped[int] = mapped_column(Integer, default=0)
    taken_at: Mapped[str | None] = mapped_column(String(32))  # EXIF DateTimeOriginal, sortable text
    created_at: Mapped[datetime] = mapped_column(Timestamp(), default=utcnow)
    sha256: Mapped[str | None] = mapped_column(String(64))  # of the file; null before 0006 and on import


class Version(Base):
    __tablename__ = "versions"

    id: Mapped[int] = mapped_column(primary_key=True)
    project_id: Mapped[int] = mapped_column(ForeignKey("projects.id", ondelete="CASCADE"), index=True)
    parent_id: Mapped[int | None] = mapped_column(ForeignKey("versions.id", ondelete="SET NULL"))
    kind: Mapped[str] = mapped_column(String(16))
    author_id: Mapped[int | None] = mapped_column(ForeignKey("users.id", ondelete="SET NULL"))
    message: Mapped[str] = mapped_column(Text, default="")
    stats: Mapped[dict[str, Any]] = mapped_column(JSON, default=dict)
    path: Mapped[str] = mapped_column(String(255))  # artifact location, relative to the store root
    edits: Mapped[dict[str, Any] | None] = mapped_column(JSON)  # the edit set applied (REST ids)
    created_at: Mapped[datetime] = mapped_column(Timestamp(), default=utcnow)

    author: Mapped[User | None] = relationship(lazy="joined")


class PairDeletion(Base):
    """A pair a version deleted from its parent's matches (REST image ids), so versions can be diffed."""

    __tablename__ = "pair_deletions"

    version_id: Mapped[int] = mapped_column(ForeignKey("versions.id", ondelete="CASCADE"), primary_key=True)
    image_id1: Mapped[int] = mapped_column(ForeignKey("images.id", ondelete="CASCADE"), primary_key=True)
    image_id2: Mapped[int] = mapped_column(ForeignKey("images.id", ondelete="CASCADE"), primary_key=True)
    tests: Mapped[list[str]] = mapped_column(JSON, default=list)


class EditSetRow(Base):
    __tablename__ = "edit_sets"

    id: Mapped[int] = mapped_column(primary_key=True)
    project_id: Mapped[int] = mapped_column(ForeignKey("projects.id", ondelete="CASCADE"), index=True)
    base_version_id: Mapped[int] = mapped_column(ForeignKey("versions.id", ondelete="CASCADE"))
    body: Mapped[dict[str, Any]] = mapped_column(JSON)
    revision: Mapped[int] = mapped_column(Integer, default=1)
    updated_by_id: Mapped[int | None] = mapped_column(ForeignKey("users.id", ondelete="SET NULL"))
    created_at: Mapped[datetime] = mapped_column(Timestamp(), default=utcnow)
    updated_at: Mapped[datetime] = mapped_column(Timestamp(), default=utcnow)
    created_by_id: Mapped[int | None] = mapped_column(ForeignKey("users.id", ondelete="SET NULL"))
    review_state: Mapped[str] = mapped_column(String(24), default="draft", server_default="draft")

    updated_by: Mapped[User | None] = relationship(lazy="joined", foreign_keys=[updated_by_id])
    created_by: Mapped[User | None] = relationship(lazy="joined", foreign_keys=[created_by_id])
    reviews: Mapped[list[Review]] = relationship(viewonly=True, order_by="Review.id", lazy="selectin")


class Webhook(Base):
    """A project's subscription: events are POSTed to `url`, signed with `secret`."""

    __tablename__ = "webhooks"

    id: Mapped[int] = mapped_column(primary_key=True)
    project_id: Mapped[int] = mapped_column(ForeignKey("projects.id", ondelete="CASCADE"), index=True)
    url: Mapped[str] = mapped_column(String(2000))
    events: Mapped[list[str]] = mapped_column(JSON)
    secret: Mapped[str] = mapped_column(String(200))  # kept readable: each delivery is signed with it
    created_at: Mapped[datetime] = mapped_column(Timestamp(), default=utcnow)


class WebhookDelivery(Base):
    """One event for one webhook: an outbox row written with the change, sent and retried after."""

    __tablename__ = "webhook_deliveries"

    id: Mapped[int] = mapped_column(primary_key=True)
    webhook_id: Mapped[int] = mapped_column(ForeignKey("webhooks.id", ondelete="CASCADE"), index=True)
    event: Mapped[str] = mapped_column(String(32))
    body: Mapped[str] = mapped_column(Text)  # the exact bytes signed and sent, as text
    at: Mapped[datetime] = mapped_column(Timestamp(), default=utcnow)
    state: Mapped[str] = mapped_column(String(16), default="pending", index=True)  # pending|ok|failed
    attempts: Mapped[int] = mapped_column(Integer, default=0)
    next_attempt_at: Mapped[datetime] = mapped_column(Timestamp(), default=utcnow)
    status_code: Mapped[int | None] = mapped_column(Integer)
    answer: Mapped[str | None] = mapped_column(Text)  # the receiver's reply or the error, cut short


class Job(Base):
    __tablename__ = "jobs"
    # One queued or running job per project, enforced by the database against racing requests.
    __table_args__ = (
        Index("uq_jobs_active_project", "project_id", unique=True,
              postgresql_where=text(ACTIVE_SQL), sqlite_where=text(ACTIVE_SQL)),
    )

    id: Mapped[int] = mapped_column(primary_key=True)
    project_id: Mapped[int] = mapped_column(ForeignKey("projects.id", ondelete="CASCADE"), index=True)
    kind: Mapped[str] = mapped_column(String(16))
    state: Mapped[str] = mapped_column(String(16), default="queued", index=True)
    stage: Mapped[str] = mapped_column(String(32), default="")
    progress: Mapped[float] = mapped_column(Float, default=0.0)
    message: Mapped[str] = mapped_column(Text, default="")
    error: Mapped[str | None] = mapped_column(Text)
    params: Mapped[dict[str, Any]] = mapped_column(JSON, default=dict)
    base_version_id: Mapped[int | None] = mapped_column(ForeignKey("versions.id", ondelete="SET NULL"))
    version_id: Mapped[int | None] = mapped_column(ForeignKey("versions.id", ondelete="SET NULL"))
    created_by: Mapped[int | None] = mapped_column(ForeignKey("users.id", ondelete="SET NULL"))
    cancel_requested: Mapped[bool] = mapped_column(Boolean, default=False)
    # {"stages": [{stage, seconds, peak_mb}], "seconds", "peak_mb"} once the job has ended
    timings: Mapped[dict[str, Any] | None] = mapped_column(JSON)
    attempts: Mapped[int] = mapped_column(Integer, default=0)
    created_at: Mapped[datetime] = mapped_column(Timestamp(), default=utcnow)
    enqueued_at: Mapped[datetime | None] = mapped_column(Timestamp())
    started_at: Mapped[datetime | None] = mapped_column(Timestamp())
    heartbeat_at: Mapped[datetime | None] = mapped_column(Timestamp())
    finished_at: Mapped[datetime | None] = mapped_column(Timestamp())


class Review(Base):
    """A verdict on one revision of an edit set by someone other than its author."""

    __tablename__ = "reviews"

    id: Mapped[int] = mapped_column(primary_key=True)
    edit_set_id: Mapped[int] = mapped_column(ForeignKey("edit_sets.id", ondelete="CASCADE"), index=True)
    reviewer_id: Mapped[int | None] = mapped_column(ForeignKey("users.id", ondelete="SET NULL"))
    verdict: Mapped[str] = mapped_column(String(24))  # approve | request_changes
    comment: Mapped[str] = mapped_column(Text, default="")
    revision: Mapped[int] = mapped_column(Integer)
    created_at: Mapped[datetime] = mapped_column(Timestamp(), default=utcnow)

    reviewer: Mapped[User | None] = relationship(lazy="joined")


class Comment(Base):
    """A plain-text comment on an image, a pair, a version, an edit set or the project."""

    __tablename__ = "comments"

    id: Mapped[int] = mapped_column(primary_key=True)
    project_id: Mapped[int] = mapped_column(ForeignKey("projects.id", ondelete="CASCADE"), index=True)
    author_id: Mapped[int | None] = mapped_column(ForeignKey("users.id", ondelete="SET NULL"))
    parent_id: Mapped[int | None] = mapped_column(ForeignKey("comments.id", ondelete="CASCADE"))
    # The target: its kind and one key column per kind (so deleting the thing deletes its comments).
    target_kind: Mapped[str] = mapped_column(String(16))  # image | pair | version | edit_set | project
    image_id: Mapped[int | None] = mapped_column(ForeignKey("images.id", ondelete="CASCADE"))
    image_id2: Mapped[int | None] = mapped_column(ForeignKey("images.id", ondelete="CASCADE"))  # of a pair
    version_id: Mapped[int | None] = mapped_column(ForeignKey("versions.id", ondelete="CASCADE"))
    edit_set_id: Mapped[int | None] = mapped_column(ForeignKey("edit_sets.id", ondelete="CASCADE"))
    body: Mapped[str] = mapped_column(Text)
    resolved: Mapped[bool] = mapped_column(Boolean, default=False)
    created_at: Mapped[datetime] = mapped_column(Timestamp(), default=utcnow)
    updated_at: Mapped[datetime] = mapped_column(Timestamp(), default=utcnow)

    author: Mapped[User | None] = relationship(lazy="joined")


class Activity(Base):
    """The append-only audit log: one row per change, never updated (the username and the access
    token's name are copied so the entry still says who after a rename or a revocation)."""

    __tablename__ = "activity"

    id: Mapped[int] = mapped_column(primary_key=True)
    project_id: Mapped[int] = mapped_column(ForeignKey("projects.id", ondelete="CASCADE"))
    at: Mapped[datetime] = mapped_column(Timestamp(), default=utcnow)
    user_id: Mapped[int | None] = mapped_column(ForeignKey("users.id", ondelete="SET NULL"))
    username: Mapped[str | None] = mapped_column(String(64))
    token_name: Mapped[str | None] = mapped_column(String(100))
    action: Mapped[str] = mapped_column(String(24))
    target: Mapped[dict[str, Any]] = mapped_column(JSON, default=dict)
    detail: Mapped[dict[str, Any]] = mapped_column(JSON, default=dict)

    __table_args__ = (Index("ix_activity_project_id_id", "project_id", "id"),)


class Presence(Base):
    """Where a member was last seen in a project (one row per member, overwritten by each report)."""

    __tablename__ = "presence"

    project_id: Mapped[int] = mapped_column(ForeignKey("projects.id", ondelete="CASCADE"), primary_key=True)
    user_id: Mapped[int] = mapped_column(ForeignKey("users.id", ondelete="CASCADE"), primary_key=True)
    edit_set_id: Mapped[int | None] = mapped_column(ForeignKey("edit_sets.id", ondelete="SET NULL"))
    version_id: Mapped[int | None] = mapped_column(ForeignKey("versions.id", ondelete="SET NULL"))
    seen_at: Mapped[datetime] = mapped_column(Timestamp(), default=utcnow)

    user: Mapped[User] = relationship(lazy="joined")


class Notification(Base):
    __tablename__ = "notifications"

    id: Mapped[int] = mapped_column(primary_key=True)
    user_id: Mapped[int] = mapped_column(ForeignKey("users.id", ondelete="CASCADE"))
    project_id: Mapped[int] = mapped_column(ForeignKey("projects.id", ondelete="CASCADE"))
    at: Mapped[datetime] = mapped_column(Timestamp(), default=utcnow)
    kind: Mapped[str] = mapped_column(String(24))
    target: Mapped[dict[str, Any]] = mapped_column(JSON, default=dict)
    text: Mapped[str] = mapped_column(Text)
    read: Mapped[bool] = mapped_column(Boolean, default=False)

    __table_args__ = (Index("ix_notifications_user_id_read", "user_id", "read"),)
