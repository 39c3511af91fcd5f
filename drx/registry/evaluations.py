"""Time-trial results: ``evaluations`` and their ``evaluation_laps``."""

from __future__ import annotations

from datetime import datetime
from typing import Any

from sqlalchemy import ForeignKey, String, UniqueConstraint
from sqlalchemy.orm import Mapped, mapped_column, relationship

from drx.registry.base import Base, utcnow


class Evaluation(Base):
    """One evaluation run of a model (a checkpoint) on a track under some race rules.

    ``rules`` holds the race settings (race type, laps, off-track penalty,
    objects/bots...). The totals are filled when the evaluation finishes.
    """

    __tablename__ = "evaluations"

    id: Mapped[int] = mapped_column(primary_key=True)
    model_id: Mapped[int] = mapped_column(ForeignKey("models.id", ondelete="CASCADE"), index=True)
    checkpoint_id: Mapped[int | None] = mapped_column(ForeignKey("checkpoints.id", ondelete="SET NULL"))
    job_id: Mapped[int | None] = mapped_column(ForeignKey("jobs.id", ondelete="SET NULL"))
    track_name: Mapped[str] = mapped_column(String(64), index=True)
    rules: Mapped[dict[str, Any]] = mapped_column(default=dict)
    status: Mapped[str] = mapped_column(String(16), default="running")  # running | complete | failed
    laps_completed: Mapped[int] = mapped_column(default=0)
    fastest_lap: Mapped[float | None]  # [s] best complete lap (penalties included)
    average_lap: Mapped[float | None]  # [s] mean of complete laps
    total_time: Mapped[float | None]  # [s] all laps, penalties included
    off_track_count: Mapped[int] = mapped_column(default=0)
    crash_count: Mapped[int] = mapped_column(default=0)
    created_at: Mapped[datetime] = mapped_column(default=utcnow)
    finished_at: Mapped[datetime | None]

    laps: Mapped[list[EvaluationLap]] = relationship(
        back_populates="evaluation", cascade="all, delete-orphan", order_by="EvaluationLap.lap"
    )


class EvaluationLap(Base):
    """One lap of an evaluation."""

    __tablename__ = "evaluation_laps"
    __table_args__ = (UniqueConstraint("evaluation_id", "lap"),)

    id: Mapped[int] = mapped_column(primary_key=True)
    evaluation_id: Mapped[int] = mapped_column(ForeignKey("evaluations.id", ondelete="CASCADE"), index=True)
    lap: Mapped[int]  # 1-based
    time: Mapped[float | None]  # [s] lap time including penalties; None when not complete
    progress: Mapped[float]  # [%]
    status: Mapped[str] = mapped_column(String(16))  # lap_complete | off_track | crashed | time_up ...
    off_track_count: Mapped[int] = mapped_column(default=0)
    penalty_seconds: Mapped[float] = mapped_column(default=0.0)  # off-track + crash penalties
    resets: Mapped[int] = mapped_column(default=0)
    crashes: Mapped[int] = mapped_column(default=0)

    evaluation: Mapped[Evaluation] = relationship(back_populates="laps")
