"""Iterations keep the figures that tell a healthy training run from a dying one.

``iteration_metrics.health`` is a JSON object per iteration (clip fraction, explained
variance, the policy's spread, the shares of sampled actions on a bound, the return scale,
the epochs run: ``drx.train.algorithms.HEALTH_FIGURES``); NULL for iterations written
before this revision and for SAC.

Revision ID: 0006h
Revises: 0005t
Create Date: 2026-11-25
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0006h"
down_revision = "0005t"
branch_labels = None
depends_on = None


def upgrade() -> None:
    # Plain ADD COLUMN of a nullable column: no table copy.
    op.add_column("iteration_metrics", sa.Column("health", sa.JSON(), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("iteration_metrics") as batch:
        batch.drop_column("health")
