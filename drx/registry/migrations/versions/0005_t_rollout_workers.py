"""Models get a rollout-worker count (processes sampling a training's episodes).

``models.rollout_workers`` is NULL for "as many as help on the machine that trains"
(:func:`drx.train.rollout.default_rollout_workers`), which is what models from before
this revision get; ``drx model create/clone --rollout-workers K`` stores K.

Revision ID: 0005t
Revises: 0004
Create Date: 2026-11-22
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0005t"
down_revision = "0004"
branch_labels = None
depends_on = None


def upgrade() -> None:
    # Plain ADD COLUMN of a nullable column: no table copy (models is referenced by other tables).
    op.add_column("models", sa.Column("rollout_workers", sa.Integer(), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("models") as batch:
        batch.drop_column("rollout_workers")
