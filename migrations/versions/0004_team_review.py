"""Team review: comments, reviews and review state of edit sets, the activity log, presence,
notifications, and the project settings require_approval and published_version_id.

Revision ID: 0004
Revises: 0003
Create Date: 2026-12-03
"""

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0004"
down_revision: str | None = "0003"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def _id(name: str, table: str, ondelete: str, nullable: bool = True) -> sa.Column:
    return sa.Column(name, sa.Integer, sa.ForeignKey(f"{table}.id", ondelete=ondelete), nullable=nullable)


def _stamp(name: str) -> sa.Column:
    return sa.Column(name, sa.DateTime(timezone=True), nullable=False)


def upgrade() -> None:
    with op.batch_alter_table("projects") as batch:
        batch.add_column(sa.Column("require_approval", sa.Boolean, nullable=False,
                                   server_default=sa.text("false")))
        batch.add_column(sa.Column("published_version_id", sa.Integer, nullable=True))
        batch.create_foreign_key("fk_projects_published_version_id_versions", "versions",
                                 ["published_version_id"], ["id"], ondelete="SET NULL")
    with op.batch_alter_table("edit_sets") as batch:
        batch.add_column(sa.Column("created_by_id", sa.Integer, nullable=True))
        batch.add_column(sa.Column("review_state", sa.String(24), nullable=False, server_default="draft"))
        batch.create_foreign_key("fk_edit_sets_created_by_id_users", "users", ["created_by_id"], ["id"],
                                 ondelete="SET NULL")
    op.execute("UPDATE edit_sets SET created_by_id = updated_by_id")
    _create_review_tables()
    _create_log_tables()


def _create_review_tables() -> None:
    op.create_table(
        "reviews",
        sa.Column("id", sa.Integer, primary_key=True),
        _id("edit_set_id", "edit_sets", "CASCADE", nullable=False),
        _id("reviewer_id", "users", "SET NULL"),
        sa.Column("verdict", sa.String(24), nullable=False),
        sa.Column("comment", sa.Text, nullable=False),
        sa.Column("revision", sa.Integer, nullable=False),
        _stamp("created_at"),
    )
    op.create_index("ix_reviews_edit_set_id", "reviews", ["edit_set_id"])
    op.create_table(
        "comments",
        sa.Column("id", sa.Integer, primary_key=True),
        _id("project_id", "projects", "CASCADE", nullable=False),
        _id("author_id", "users", "SET NULL"),
        _id("parent_id", "comments", "CASCADE"),
        sa.Column("target_kind", sa.String(16), nullable=False),
        _id("image_id", "images", "CASCADE"),
        _id("image_id2", "images", "CASCADE"),
        _id("version_id", "versions", "CASCADE"),
        _id("edit_set_id", "edit_sets", "CASCADE"),
        sa.Column("body", sa.Text, nullable=False),
        sa.Column("resolved", sa.Boolean, nullable=False),
        _stamp("created_at"),
        _stamp("updated_at"),
    )
    op.create_index("ix_comments_project_id", "comments", ["project_id"])


def _create_log_tables() -> None:
    op.create_table(
        "activity",
        sa.Column("id", sa.Integer, primary_key=True),
        _id("project_id", "projects", "CASCADE", nullable=False),
        _stamp("at"),
        _id("user_id", "users", "SET NULL"),
        sa.Column("username", sa.String(64), nullable=True),
        sa.Column("token_name", sa.String(100), nullable=True),
        sa.Column("action", sa.String(24), nullable=False),
        sa.Column("target", sa.JSON, nullable=False),
        sa.Column("detail", sa.JSON, nullable=False),
    )
    op.create_index("ix_activity_project_id_id", "activity", ["project_id", "id"])
    op.create_table(
        "presence",
        _id("project_id", "projects", "CASCADE", nullable=False),
        _id("user_id", "users", "CASCADE", nullable=False),
        _id("edit_set_id", "edit_sets", "SET NULL"),
        _id("version_id", "versions", "SET NULL"),
        _stamp("seen_at"),
        sa.PrimaryKeyConstraint("project_id", "user_id", name="pk_presence"),
    )
    op.create_table(
        "notifications",
        sa.Column("id", sa.Integer, primary_key=True),
        _id("user_id", "users", "CASCADE", nullable=False),
        _id("project_id", "projects", "CASCADE", nullable=False),
        _stamp("at"),
        sa.Column("kind", sa.String(24), nullable=False),
        sa.Column("target", sa.JSON, nullable=False),
        sa.Column("text", sa.Text, nullable=False),
        sa.Column("read", sa.Boolean, nullable=False),
    )
    op.create_index("ix_notifications_user_id_read", "notifications", ["user_id", "read"])


def downgrade() -> None:
    op.drop_index("ix_notifications_user_id_read", table_name="notifications")
    op.drop_table("notifications")
    op.drop_table("presence")
    op.drop_index("ix_activity_project_id_id", table_name="activity")
    op.drop_table("activity")
    op.drop_index("ix_comments_project_id", table_name="comments")
    op.drop_table("comments")
    op.drop_index("ix_reviews_edit_set_id", table_name="reviews")
    op.drop_table("reviews")
    with op.batch_alter_table("edit_sets") as batch:
        batch.drop_constraint("fk_edit_sets_created_by_id_users", type_="foreignkey")
        batch.drop_column("review_state")
        batch.drop_column("created_by_id")
    with op.batch_alter_table("projects") as batch:
        batch.drop_constraint("fk_projects_published_version_id_versions", type_="foreignkey")
        batch.drop_column("published_version_id")
        batch.drop_column("require_approval")
