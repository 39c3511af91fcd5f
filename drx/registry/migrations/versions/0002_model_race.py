"""Models get a race: time trial, object avoidance or head-to-bot, with its settings.

Revision ID: 0002
Revises: 0001
Create Date: 2026-11-21
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0002"
down_revision = "0001"
branch_labels = None
depends_on = None

# Models created before race types existed are time trials.
TIME_TRIAL = {
    "race_type": "time-trial",
    "objects": 0,
    "object_positions": [],
    "randomize_objects": False,
    "bots": 0,
    "bot_speed": None,
    "bot_lane_change": False,
    "randomize_bots": False,
}


def upgrade() -> None:
    with op.batch_alter_table("models") as batch:
        batch.add_column(sa.Column("race", sa.JSON(), nullable=True))
    # A typed table construct, so the value is bound as JSON on every backend (PostgreSQL
    # refuses a string bound to a json column).
    models = sa.table("models", sa.column("race", sa.JSON()))
    op.execute(models.update().values(race=TIME_TRIAL))
    with op.batch_alter_table("models") as batch:
        batch.alter_column("race", existing_type=sa.JSON(), nullable=False)


def downgrade() -> None:
    with op.batch_alter_table("models") as batch:
        batch.drop_column("race")
