"""Initial registry: vehicles, tracks, reward sources, models, jobs, training results, evaluations.

Revision ID: 0001
Revises:
Create Date: 2026-11-21
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0001"
down_revision = None
branch_labels = None
depends_on = None


def _ts(name: str, nullable: bool = False) -> sa.Column:
    return sa.Column(name, sa.DateTime(), nullable=nullable)


def upgrade() -> None:
    op.create_table(
        "vehicles",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column("name", sa.String(64), nullable=False),
        sa.Column("spec", sa.JSON(), nullable=False),
        sa.Column("source", sa.String(512), nullable=True),
        _ts("created_at"),
        sa.UniqueConstraint("name", name="uq_vehicles_name"),
    )
    op.create_table(
        "tracks",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column("name", sa.String(64), nullable=False),
        sa.Column("path", sa.String(1024), nullable=False),
        sa.Column("source_path", sa.String(1024), nullable=True),
        sa.Column("sha256", sa.String(64), nullable=False),
        sa.Column("length", sa.Float(), nullable=False),
        sa.Column("width", sa.Float(), nullable=False),
        sa.Column("direction", sa.String(8), nullable=False),
        sa.Column("closed", sa.Boolean(), nullable=False),
        sa.Column("n_waypoints", sa.Integer(), nullable=False),
        sa.Column("notes", sa.JSON(), nullable=False),
        _ts("created_at"),
        sa.UniqueConstraint("name", name="uq_tracks_name"),
    )
    op.create_table(
        "reward_sources",
        sa.Column("sha256", sa.String(64), primary_key=True),
        sa.Column("code", sa.Text(), nullable=False),
        sa.Column("filename", sa.String(512), nullable=False),
        _ts("created_at"),
    )
    op.create_table(
        "models",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column("name", sa.String(64), nullable=False),
        sa.Column("description", sa.String(1024), nullable=True),
        sa.Column("vehicle_name", sa.String(64), nullable=False),
        sa.Column("vehicle_spec", sa.JSON(), nullable=False),
        sa.Column("track_name", sa.String(64), nullable=False),
        sa.Column("track_sha256", sa.String(64), nullable=True),
        sa.Column(
            "reward_sha256",
            sa.String(64),
            sa.ForeignKey("reward_sources.sha256", name="fk_models_reward_sha256_reward_sources"),
            nullable=False,
        ),
        sa.Column("reward_filename", sa.String(512), nullable=False),
        sa.Column("algorithm", sa.String(8), nullable=False),
        sa.Column("hyperparameters", sa.JSON(), nullable=False),
        sa.Column("stop_conditions", sa.JSON(), nullable=False),
        sa.Column("status", sa.String(16), nullable=False),
        sa.Column(
            "parent_id",
            sa.Integer(),
            sa.ForeignKey("models.id", name="fk_models_parent_id_models", ondelete="SET NULL"),
            nullable=True,
        ),
        sa.Column("parent_name", sa.String(64), nullable=True),
        sa.Column("parent_checkpoint_id", sa.Integer(), nullable=True),
        _ts("created_at"),
        _ts("updated_at"),
        sa.UniqueConstraint("name", name="uq_models_name"),
    )
    op.create_index("ix_models_parent_id", "models", ["parent_id"])
    op.create_table(
        "jobs",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column(
            "model_id",
            sa.Integer(),
            sa.ForeignKey("models.id", name="fk_jobs_model_id_models", ondelete="CASCADE"),
            nullable=False,
        ),
        sa.Column("kind", sa.String(16), nullable=False),
        sa.Column("status", sa.String(16), nullable=False),
        sa.Column("options", sa.JSON(), nullable=False),
        _ts("created_at"),
        _ts("started_at", True),
        _ts("finished_at", True),
        _ts("heartbeat_at", True),
        sa.Column("worker_id", sa.String(128), nullable=True),
        sa.Column("lease_seconds", sa.Integer(), nullable=False),
        sa.Column("attempts", sa.Integer(), nullable=False),
        sa.Column("max_attempts", sa.Integer(), nullable=False),
        sa.Column("stop_requested", sa.Boolean(), nullable=False),
        sa.Column("stop_reason", sa.String(256), nullable=True),
        sa.Column("error", sa.Text(), nullable=True),
        sa.Column("log_path", sa.String(1024), nullable=True),
    )
    op.create_index("ix_jobs_model_id", "jobs", ["model_id"])
    op.create_index("ix_jobs_status_created_at", "jobs", ["status", "created_at"])

    def model_fk(table: str) -> sa.Column:
        return sa.Column(
            "model_id",
            sa.Integer(),
            sa.ForeignKey("models.id", name=f"fk_{table}_model_id_models", ondelete="CASCADE"),
            nullable=False,
        )

    def job_fk(table: str) -> sa.Column:
        return sa.Column(
            "job_id",
            sa.Integer(),
            sa.ForeignKey("jobs.id", name=f"fk_{table}_job_id_jobs", ondelete="SET NULL"),
            nullable=True,
        )

    op.create_table(
        "checkpoints",
        sa.Column("id", sa.Integer(), primary_key=True),
        model_fk("checkpoints"),
        job_fk("checkpoints"),
        sa.Column("iteration", sa.Integer(), nullable=False),
        sa.Column("path", sa.String(1024), nullable=False),
        sa.Column("steps", sa.Integer(), nullable=False),
        sa.Column("episodes", sa.Integer(), nullable=False),
        sa.Column("eval_progress", sa.Float(), nullable=True),
        sa.Column("eval_lap_time", sa.Float(), nullable=True),
        sa.Column("is_best", sa.Boolean(), nullable=False),
        _ts("created_at"),
        sa.UniqueConstraint("model_id", "iteration", name="uq_checkpoints_model_id_iteration"),
    )
    op.create_index("ix_checkpoints_model_id", "checkpoints", ["model_id"])
    with op.batch_alter_table("models") as batch:
        batch.create_foreign_key(
            "fk_models_parent_checkpoint_id_checkpoints",
            "checkpoints",
            ["parent_checkpoint_id"],
            ["id"],
            ondelete="SET NULL",
        )
    op.create_table(
        "episodes",
        sa.Column("id", sa.Integer(), primary_key=True),
        model_fk("episodes"),
        job_fk("episodes"),
        sa.Column("iteration", sa.Integer(), nullable=False),
        sa.Column("episode", sa.Integer(), nullable=False),
        sa.Column("phase", sa.String(16), nullable=False),
        sa.Column("reward", sa.Float(), nullable=False),
        sa.Column("progress", sa.Float(), nullable=False),
        sa.Column("steps", sa.Integer(), nullable=False),
        sa.Column("status", sa.String(16), nullable=False),
        sa.Column("lap_time", sa.Float(), nullable=True),
        sa.Column("start_fraction", sa.Float(), nullable=False),
        _ts("created_at"),
        sa.UniqueConstraint(
            "model_id", "phase", "iteration", "episode", name="uq_episodes_model_id_phase_iteration_episode"
        ),
    )
    op.create_index("ix_episodes_model_id", "episodes", ["model_id"])
    op.create_table(
        "iteration_metrics",
        sa.Column("id", sa.Integer(), primary_key=True),
        model_fk("iteration_metrics"),
        job_fk("iteration_metrics"),
        sa.Column("iteration", sa.Integer(), nullable=False),
        *[
            sa.Column(name, sa.Float(), nullable=True)
            for name in ("policy_loss", "value_loss", "entropy", "kl", "learning_rate")
        ],
        sa.Column("steps", sa.Integer(), nullable=False),
        sa.Column("episodes", sa.Integer(), nullable=False),
        *[
            sa.Column(name, sa.Float(), nullable=True)
            for name in (
                "steps_per_second",
                "elapsed_seconds",
                "train_mean_reward",
                "train_mean_progress",
                "eval_mean_reward",
                "eval_mean_progress",
            )
        ],
        _ts("created_at"),
        sa.UniqueConstraint("model_id", "iteration", name="uq_iteration_metrics_model_id_iteration"),
    )
    op.create_index("ix_iteration_metrics_model_id", "iteration_metrics", ["model_id"])
    op.create_table(
        "evaluations",
        sa.Column("id", sa.Integer(), primary_key=True),
        model_fk("evaluations"),
        sa.Column(
            "checkpoint_id",
            sa.Integer(),
            sa.ForeignKey(
                "checkpoints.id", name="fk_evaluations_checkpoint_id_checkpoints", ondelete="SET NULL"
            ),
            nullable=True,
        ),
        job_fk("evaluations"),
        sa.Column("track_name", sa.String(64), nullable=False),
        sa.Column("rules", sa.JSON(), nullable=False),
        sa.Column("status", sa.String(16), nullable=False),
        sa.Column("laps_completed", sa.Integer(), nullable=False),
        sa.Column("fastest_lap", sa.Float(), nullable=True),
        sa.Column("average_lap", sa.Float(), nullable=True),
        sa.Column("total_time", sa.Float(), nullable=True),
        sa.Column("off_track_count", sa.Integer(), nullable=False),
        sa.Column("crash_count", sa.Integer(), nullable=False),
        _ts("created_at"),
        _ts("finished_at", True),
    )
    op.create_index("ix_evaluations_model_id", "evaluations", ["model_id"])
    op.create_index("ix_evaluations_track_name", "evaluations", ["track_name"])
    op.create_table(
        "evaluation_laps",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column(
            "evaluation_id",
            sa.Integer(),
            sa.ForeignKey(
                "evaluations.id", name="fk_evaluation_laps_evaluation_id_evaluations", ondelete="CASCADE"
            ),
            nullable=False,
        ),
        sa.Column("lap", sa.Integer(), nullable=False),
        sa.Column("time", sa.Float(), nullable=True),
        sa.Column("progress", sa.Float(), nullable=False),
        sa.Column("status", sa.String(16), nullable=False),
        sa.Column("off_track_count", sa.Integer(), nullable=False),
        sa.Column("penalty_seconds", sa.Float(), nullable=False),
        sa.Column("resets", sa.Integer(), nullable=False),
        sa.Column("crashes", sa.Integer(), nullable=False),
        sa.UniqueConstraint("evaluation_id", "lap", name="uq_evaluation_laps_evaluation_id_lap"),
    )
    op.create_index("ix_evaluation_laps_evaluation_id", "evaluation_laps", ["evaluation_id"])


def downgrade() -> None:
    for index, table in (
        ("ix_evaluation_laps_evaluation_id", "evaluation_laps"),
        ("ix_evaluations_track_name", "evaluations"),
        ("ix_evaluations_model_id", "evaluations"),
        ("ix_iteration_metrics_model_id", "iteration_metrics"),
        ("ix_episodes_model_id", "episodes"),
    ):
        op.drop_index(index, table_name=table)
    for table in ("evaluation_laps", "evaluations", "iteration_metrics", "episodes"):
        op.drop_table(table)
    with op.batch_alter_table("models") as batch:
        batch.drop_constraint("fk_models_parent_checkpoint_id_checkpoints", type_="foreignkey")
    op.drop_index("ix_checkpoints_model_id", table_name="checkpoints")
    op.drop_table("checkpoints")
    op.drop_index("ix_jobs_status_created_at", table_name="jobs")
    op.drop_index("ix_jobs_model_id", table_name="jobs")
    op.drop_table("jobs")
    op.drop_index("ix_models_parent_id", table_name="models")
    for table in ("models", "reward_sources", "tracks", "vehicles"):
        op.drop_table(table)
