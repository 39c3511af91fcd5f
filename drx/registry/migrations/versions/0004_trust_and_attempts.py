"""Reward sources know whether they may run; jobs keep why each attempt ended.

``reward_sources.trusted`` is false for a reward function that came in an imported package
and was not trusted (``drx model import`` without ``--trust-reward``): drx stores and shows
it but runs it only after ``--trust-reward``. ``jobs.attempt_log`` lists the end of every
attempt (requeued by a shutdown or a silent worker, failed, finished) with its reason.

Revision ID: 0004
Revises: 0003
Create Date: 2026-11-22
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0004"
down_revision = "0003"
branch_labels = None
depends_on = None


def upgrade() -> None:
    # Plain ADD COLUMN (SQLite supports it with a constant default): a batch copy of
    # reward_sources would drop a table that models reference.
    trusted: sa.Column[bool] = sa.Column("trusted", sa.Boolean(), nullable=False, server_default=sa.true())
    op.add_column("reward_sources", trusted)
    op.add_column("jobs", sa.Column("attempt_log", sa.JSON(), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("jobs") as batch:
        batch.drop_column("attempt_log")
    with op.batch_alter_table("reward_sources") as batch:
        batch.drop_column("trusted")
