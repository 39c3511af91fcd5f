"""Models get a device setting; training jobs record the device they ran on.

``models.device`` is the torch device a model trains on: ``cpu``, ``cuda``, ``cuda:N`` or ``mps``
(:mod:`drx.settings.device`), NULL for ``auto`` (a GPU torch can use, else the CPU), which is what
models from before this revision get: they trained on the CPU, and ``auto`` is the CPU on every
machine without a GPU. ``jobs.device`` is the device a training job's latest attempt ran on, as
``drx jobs show`` names it (``cpu``, ``cuda:0 (NVIDIA A10G)``); NULL for evaluations and for
jobs from before this revision.

Revision ID: 0008d
Revises: 0007o
Create Date: 2026-11-29
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0008d"
down_revision = "0007o"
branch_labels = None
depends_on = None


def upgrade() -> None:
    # Plain ADD COLUMN of nullable columns: no table copy (both tables are referenced by others).
    op.add_column("models", sa.Column("device", sa.String(length=16), nullable=True))
    op.add_column("jobs", sa.Column("device", sa.String(length=128), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("jobs") as batch:
        batch.drop_column("device")
    with op.batch_alter_table("models") as batch:
        batch.drop_column("device")
