"""Initial schema: users, projects, memberships, images, versions, pair deletions, edit sets, jobs.

Revision ID: 0001
Revises:
Create Date: 2025-11-23
"""

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0001"
down_revision: str | None = None
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None

ACTIVE = sa.text("state IN ('queued', 'running')")


def ts(name: str, nullable: bool = True) -> sa.Column:
    return sa.Column(name, sa.DateTime(timezone=True), nullable=nullable)


def fk(name: str, target: str, ondelete: str, nullable: bool = True, **kw) -> sa.Column:
    return sa.Column(name, sa.Integer, sa.ForeignKey(target, ondelete=ondelete), nullable=nullable, **kw)


def upgrade() -> None:
    op.create_table(
        "users",
        sa.Column("id", sa.Integer, primary_key=True),
        sa.Column("username", sa.String(64), nullable=False, unique=True),
        sa.Column("password_hash", sa.String(255), nullable=False),
        ts("created_at", False),
    )
    op.create_table(
        "projects",
        sa.Column("id", sa.Integer, primary_key=True),
        sa.Column("name", sa.String(200), nullable=False),
        sa.Column("description", sa.Text, nullable=False),
        fk("created_by", "users.id", "SET NULL"),
        sa.Column("head_version_id", sa.Integer, nullable=True),  # FK added once versions exist
        ts("created_at", False),
    )
    op.create_table(
        "memberships",
        fk("project_id", "projects.id", "CASCADE", False, primary_key=True),
        fk("user_id", "users.id", "CASCADE", False, primary_key=True),
        sa.Column("role", sa.String(16), nullable=False),
    )
    op.create_table(
        "images",
        sa.Column("id", sa.Integer, primary_key=True),
        fk("project_id", "projects.id", "CASCADE", False, index=True),
        sa.Column("name", sa.String(255), nullable=False),
        sa.Column("width", sa.Integer, nullable=False),
        sa.Column("height", sa.Integer, nullable=False),
        sa.Column("seq", sa.Integer, nullable=False),
        sa.Column("taken_at", sa.String(32), nullable=True),
        ts("created_at", False),
        sa.UniqueConstraint("project_id", "name", name="uq_images_project_id_name"),
    )
    op.create_table(
        "versions",
        sa.Column("id", sa.Integer, primary_key=True),
        fk("project_id", "projects.id", "CASCADE", False, index=True),
        fk("parent_id", "versions.id", "SET NULL"),
        sa.Column("kind", sa.String(16), nullable=False),
        fk("author_id", "users.id", "SET NULL"),
        sa.Column("message", sa.Text, nullable=False),
        sa.Column("stats", sa.JSON, nullable=False),
        sa.Column("path", sa.String(255), nullable=False),
        sa.Column("edits", sa.JSON, nullable=True),
        ts("created_at", False),
    )
    with op.batch_alter_table("projects") as batch:
        batch.create_foreign_key(
            "fk_projects_head_version_id_versions", "versions", ["head_version_id"], ["id"],
            ondelete="SET NULL",
        )
    op.create_table(
        "pair_deletions",
        fk("version_id", "versions.id", "CASCADE", False, primary_key=True),
        fk("image_id1", "images.id", "CASCADE", False, primary_key=True),
        fk("image_id2", "images.id", "CASCADE", False, primary_key=True),
        sa.Column("tests", sa.JSON, nullable=False),
    )
    op.create_table(
        "edit_sets",
        sa.Column("id", sa.Integer, primary_key=True),
        fk("project_id", "projects.id", "CASCADE", False, index=True),
        fk("base_version_id", "versions.id", "CASCADE", False),
        sa.Column("body", sa.JSON, nullable=False),
        sa.Column("revision", sa.Integer, nullable=False),
        fk("updated_by_id", "users.id", "SET NULL"),
        ts("created_at", False),
        ts("updated_at", False),
    )
    op.create_table(
        "jobs",
        sa.Column("id", sa.Integer, primary_key=True),
        fk("project_id", "projects.id", "CASCADE", False, index=True),
        sa.Column("kind", sa.String(16), nullable=False),
        sa.Column("state", sa.String(16), nullable=False, index=True),
        sa.Column("stage", sa.String(32), nullable=False),
        sa.Column("progress", sa.Float, nullable=False),
        sa.Column("message", sa.Text, nullable=False),
        sa.Column("error", sa.Text, nullable=True),
        sa.Column("params", sa.JSON, nullable=False),
        fk("base_version_id", "versions.id", "SET NULL"),
        fk("version_id", "versions.id", "SET NULL"),
        fk("created_by", "users.id", "SET NULL"),
        sa.Column("cancel_requested", sa.Boolean, nullable=False),
        sa.Column("attempts", sa.Integer, nullable=False),
        ts("created_at", False),
        ts("enqueued_at"),
        ts("started_at"),
        ts("heartbeat_at"),
        ts("finished_at"),
    )
    # One queued or running job per project, enforced by the database against racing requests.
    op.create_index("uq_jobs_active_project", "jobs", ["project_id"], unique=True,
                    postgresql_where=ACTIVE, sqlite_where=ACTIVE)


def downgrade() -> None:
    op.drop_index("uq_jobs_active_project", table_name="jobs")
    for table in ("jobs", "edit_sets", "pair_deletions"):
        op.drop_table(table)
    with op.batch_alter_table("projects") as batch:
        batch.drop_constraint("fk_projects_head_version_id_versions", type_="foreignkey")
    for table in ("versions", "images", "memberships", "projects", "users"):
        op.drop_table(table)
