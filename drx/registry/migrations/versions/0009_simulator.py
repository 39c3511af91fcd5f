"""Models get the DeepRacer simulator whose car they train on, and car randomization.

``models.simulator`` is the simulator version whose car a model trains and races on (``"5"`` or
``"6"``, :mod:`drx.settings.car`). Models from before this revision trained on version 5's car (the
only one drx had), so they keep it: the column's server default fills them with ``"5"``; new models
get ``"6"`` from the service layer (the car DeepRacer on AWS and deepracer-for-cloud race on).
``models.car_randomization``: training episodes draw a car between versions 5 and 6; off for
every model from before.

Revision ID: 0009s
Revises: 0008d
Create Date: 2026-11-28
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0009s"
down_revision = "0008d"
branch_labels = None
depends_on = None


def upgrade() -> None:
    # Plain ADD COLUMN with server defaults: no table copy (models is referenced by other tables).
    op.add_column("models", sa.Column("simulator", sa.String(length=4), nullable=False, server_default="5"))
    op.add_column(
        "models", sa.Column("car_randomization", sa.Boolean(), nullable=False, server_default=sa.false())
    )


def downgrade() -> None:
    with op.batch_alter_table("models") as batch:
        batch.drop_column("car_randomization")
        batch.drop_column("simulator")
