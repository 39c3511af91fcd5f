"""Models keep where and which way their training episodes start, and on which tracks; episodes
keep the track they drove.

``models.episode_options`` is a JSON object (:meth:`drx.settings.episodes.EpisodeSettings.to_dict`:
the tracks, the first being ``track_name``, with the direction each is driven; DeepRacer's
ALTERNATE_DRIVING_DIRECTION, CHANGE_START_POSITION, ROUND_ROBIN_ADVANCE_DIST and
START_POSITION_OFFSET). NULL for models from before this revision, which read as their one track,
its route's own way, with DeepRacer's defaults: exactly how they trained.

``episodes.track_name`` is the route an episode drove, so a model training on several tracks keeps
each track's figures apart; NULL for episodes from before this revision (their model's one track).

Revision ID: 0007o
Revises: 0006h
Create Date: 2026-11-27
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0007o"
down_revision = "0006h"
branch_labels = None
depends_on = None


def upgrade() -> None:
    # Plain ADD COLUMN of nullable columns: no table copy (both tables are referenced or large).
    op.add_column("models", sa.Column("episode_options", sa.JSON(), nullable=True))
    op.add_column("episodes", sa.Column("track_name", sa.String(length=64), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("episodes") as batch:
        batch.drop_column("track_name")
    with op.batch_alter_table("models") as batch:
        batch.drop_column("episode_options")
