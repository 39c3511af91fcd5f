"""Training results: ``checkpoints``, ``episodes`` and ``iteration_metrics``.

Rows carry ``model_id`` (and the ``job_id`` that wrote them, kept NULL-able so
removing a job keeps the history). The unique keys make writes idempotent: a
resumed job that replays an iteration updates rows instead of counting twice.
"""

from __future__ import annotations

from datetime import datetime

from sqlalchemy import JSON, ForeignKey, String, UniqueConstraint, func, select
from sqlalchemy.orm import Mapped, Session, mapped_column

from drx.registry.base import Base, utcnow

EPISODE_PHASES = ("training", "evaluation")


class Checkpoint(Base):
    """Saved policy weights after an iteration."""

    __tablename__ = "checkpoints"
    __table_args__ = (UniqueConstraint("model_id", "iteration"),)

    id: Mapped[int] = mapped_column(primary_key=True)
    model_id: Mapped[int] = mapped_column(ForeignKey("models.id", ondelete="CASCADE"), index=True)
    job_id: Mapped[int | None] = mapped_column(ForeignKey("jobs.id", ondelete="SET NULL"))
    iteration: Mapped[int]
    path: Mapped[str] = mapped_column(String(1024))
    steps: Mapped[int] = mapped_column(default=0)  # total environment steps so far
    episodes: Mapped[int] = mapped_column(default=0)  # total training episodes so far
    eval_progress: Mapped[float | None]  # [%] mean evaluation progress of this iteration
    eval_lap_time: Mapped[float | None]  # [s] mean complete-lap time, when any lap completed
    is_best: Mapped[bool] = mapped_column(default=False)
    created_at: Mapped[datetime] = mapped_column(default=utcnow)


class Episode(Base):
    """One training or evaluation episode."""

    __tablename__ = "episodes"
    __table_args__ = (UniqueConstraint("model_id", "phase", "iteration", "episode"),)

    id: Mapped[int] = mapped_column(primary_key=True)
    model_id: Mapped[int] = mapped_column(ForeignKey("models.id", ondelete="CASCADE"), index=True)
    job_id: Mapped[int | None] = mapped_column(ForeignKey("jobs.id", ondelete="SET NULL"))
    iteration: Mapped[int]
    episode: Mapped[int]  # index within the iteration and phase
    phase: Mapped[str] = mapped_column(String(16))  # training | evaluation
    reward: Mapped[float]  # sum over the episode
    progress: Mapped[float]  # [%]
    steps: Mapped[int]
    status: Mapped[str] = mapped_column(String(16))  # DeepRacer episode_status at the end
    lap_time: Mapped[float | None]  # [s] simulated, when the lap completed
    start_fraction: Mapped[float] = mapped_column(default=0.0)  # [0, 1) of the lap where it started
    # the route it drove (a model training on several tracks); NULL before revision 0007o
    track_name: Mapped[str | None] = mapped_column(String(64), default=None)
    created_at: Mapped[datetime] = mapped_column(default=utcnow)


class IterationMetric(Base):
    """Per-iteration training statistics (one row per model and iteration)."""

    __tablename__ = "iteration_metrics"
    __table_args__ = (UniqueConstraint("model_id", "iteration"),)

    id: Mapped[int] = mapped_column(primary_key=True)
    model_id: Mapped[int] = mapped_column(ForeignKey("models.id", ondelete="CASCADE"), index=True)
    job_id: Mapped[int | None] = mapped_column(ForeignKey("jobs.id", ondelete="SET NULL"))
    iteration: Mapped[int]
    policy_loss: Mapped[float | None]
    value_loss: Mapped[float | None]
    entropy: Mapped[float | None]
    kl: Mapped[float | None]
    learning_rate: Mapped[float | None]
    steps: Mapped[int] = mapped_column(default=0)  # total environment steps so far
    episodes: Mapped[int] = mapped_column(default=0)  # total training episodes so far
    steps_per_second: Mapped[float | None]
    elapsed_seconds: Mapped[float | None]  # wall-clock training time so far
    train_mean_reward: Mapped[float | None]
    train_mean_progress: Mapped[float | None]
    eval_mean_reward: Mapped[float | None]
    eval_mean_progress: Mapped[float | None]
    # the update's health figures (drx.train.records.IterationSummary.health) and the anneal
    # schedule's (drx.train.anneal.FIGURES: lr_factor, and rollback_to... on a rollback);
    # NULL before revision 0006h
    health: Mapped[dict[str, float] | None] = mapped_column(JSON, default=None)
    created_at: Mapped[datetime] = mapped_column(default=utcnow)


def iterations_so_far(session: Session, model_id: int) -> tuple[list[IterationMetric], int]:
    """A model's finished iterations in order, and how many training episodes the iteration under way
    holds (what the dashboard of ``drx jobs logs`` and the ``drx watch`` page show)."""
    rows = list(
        session.scalars(
            select(IterationMetric)
            .where(IterationMetric.model_id == model_id)
            .order_by(IterationMetric.iteration)
        )
    )
    running = rows[-1].iteration + 1 if rows else 0
    current = session.scalar(
        select(func.count(Episode.id)).where(
            Episode.model_id == model_id, Episode.phase == "training", Episode.iteration == running
        )
    )
    return rows, int(current or 0)


def training_by_track(session: Session, model_id: int) -> dict[int, dict[str, tuple[int, float, float]]]:
    """A model's training episodes per iteration and track (those that record their track):
    ``{iteration: {track: (episodes, mean reward, mean progress)}}``, iterations in order, tracks in
    the order of their names. Empty for a model whose episodes name no track."""
    rows = session.execute(
        select(
            Episode.iteration,
            Episode.track_name,
            func.count(Episode.id),
            func.avg(Episode.reward),
            func.avg(Episode.progress),
        )
        .where(Episode.model_id == model_id, Episode.phase == "training", Episode.track_name.is_not(None))
        .group_by(Episode.iteration, Episode.track_name)
        .order_by(Episode.iteration, Episode.track_name)
    )
    out: dict[int, dict[str, tuple[int, float, float]]] = {}
    for iteration, track, count, reward, progress in rows:
        out.setdefault(int(iteration), {})[str(track)] = (int(count), float(reward), float(progress))
    return out
