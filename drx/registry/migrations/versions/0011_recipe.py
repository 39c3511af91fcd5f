"""Models record the recipe they were built by (``drx model create --recipe``, issue 41).

``models.recipe`` is the recipe's name, the kind of car it built and every choice it made with its
reason (:meth:`drx.recipes.race_pace.Recipe.to_dict`), which ``drx model show`` lists; NULL for a
model made without one, as every model from before this revision was.

Revision ID: 0011r
Revises: 0010h
Create Date: 2026-12-01
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0011r"
down_revision = "0010h"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.add_column("models", sa.Column("recipe", sa.JSON(), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("models") as batch:
        batch.drop_column("recipe")
