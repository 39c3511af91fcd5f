"""Head-to-head races: ``races`` and their ``race_entries`` (``drx race``, issue 39).

A race is two to four models on one track at once under DeepRacer's multi-car rules; each of
its cars is an entry with its place, laps, lap times, time, collisions and penalties. Matches of
a bracket (``drx race --bracket``) are races with ``bracket`` and ``bracket_round`` set. Two new
tables only: nothing else changes, so the revision can follow any head.

Revision ID: 0010h
Revises: 0009s
Create Date: 2026-11-28
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0010h"
down_revision = "0009s"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "races",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column("track_name", sa.String(64), nullable=False),
        sa.Column("rules", sa.JSON(), nullable=False),
        sa.Column("ended", sa.String(16), nullable=False),
        sa.Column("race_time", sa.Float(), nullable=False),
        sa.Column("seed", sa.Integer(), nullable=False),
        sa.Column("bracket", sa.String(40), nullable=True),
        sa.Column("bracket_round", sa.Integer(), nullable=True),
        sa.Column("video", sa.String(1024), nullable=True),
        sa.Column("created_at", sa.DateTime(), nullable=False),
    )
    op.create_index("ix_races_track_name", "races", ["track_name"])
    op.create_index("ix_races_bracket", "races", ["bracket"])
    op.create_table(
        "race_entries",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column(
            "race_id",
            sa.Integer(),
            sa.ForeignKey("races.id", name="fk_race_entries_race_id_races", ondelete="CASCADE"),
            nullable=False,
        ),
        sa.Column(
            "model_id",
            sa.Integer(),
            sa.ForeignKey("models.id", name="fk_race_entries_model_id_models", ondelete="CASCADE"),
            nullable=False,
        ),
        sa.Column(
            "checkpoint_id",
            sa.Integer(),
            sa.ForeignKey(
                "checkpoints.id", name="fk_race_entries_checkpoint_id_checkpoints", ondelete="SET NULL"
            ),
            nullable=True,
        ),
        sa.Column("start_index", sa.Integer(), nullable=False),
        sa.Column("place", sa.Integer(), nullable=False),
        sa.Column("status", sa.String(16), nullable=False),
        sa.Column("laps", sa.Integer(), nullable=False),
        sa.Column("lap_times", sa.JSON(), nullable=False),
        sa.Column("time", sa.Float(), nullable=True),
        sa.Column("progress", sa.Float(), nullable=False),
        sa.Column("collisions", sa.Integer(), nullable=False),
        sa.Column("crashes", sa.Integer(), nullable=False),
        sa.Column("off_track_count", sa.Integer(), nullable=False),
        sa.Column("penalty_seconds", sa.Float(), nullable=False),
        sa.Column("trace", sa.String(1024), nullable=True),
        sa.UniqueConstraint("race_id", "start_index", name="uq_race_entries_race_id_start_index"),
    )
    op.create_index("ix_race_entries_race_id", "race_entries", ["race_id"])
    op.create_index("ix_race_entries_model_id", "race_entries", ["model_id"])


def downgrade() -> None:
    op.drop_index("ix_race_entries_model_id", table_name="race_entries")
    op.drop_index("ix_race_entries_race_id", table_name="race_entries")
    op.drop_table("race_entries")
    op.drop_index("ix_races_bracket", table_name="races")
    op.drop_index("ix_races_track_name", table_name="races")
    op.drop_table("races")
