"""Head-to-head results: ``races`` (one race of two to four models) and their ``race_entries``."""

from __future__ import annotations

from datetime import datetime
from typing import Any

from sqlalchemy import ForeignKey, String, UniqueConstraint
from sqlalchemy.orm import Mapped, mapped_column, relationship

from drx.registry.base import Base, utcnow


class Race(Base):
    """One head-to-head race (``drx race``), alone or a match of a bracket.

    ``rules`` holds DeepRacer's multi-car rules it ran under (laps, penalties, done condition,
    start offset, direction). ``bracket`` names the bracket a match belongs to (``None`` for a race
    of its own) and ``bracket_round`` its round (1 = first).
    """

    __tablename__ = "races"

    id: Mapped[int] = mapped_column(primary_key=True)
    track_name: Mapped[str] = mapped_column(String(64), index=True)
    rules: Mapped[dict[str, Any]] = mapped_column(default=dict)
    ended: Mapped[str] = mapped_column(String(16))  # any_finished | all_finished | time_cap
    race_time: Mapped[float]  # [s] the race clock at the end
    seed: Mapped[int]
    bracket: Mapped[str | None] = mapped_column(String(40), index=True)
    bracket_round: Mapped[int | None]
    video: Mapped[str | None] = mapped_column(String(1024))
    created_at: Mapped[datetime] = mapped_column(default=utcnow)

    entries: Mapped[list[RaceEntry]] = relationship(
        back_populates="race", cascade="all, delete-orphan", order_by="RaceEntry.place"
    )


class RaceEntry(Base):
    """One car of a race: its model and how it did."""

    __tablename__ = "race_entries"
    __table_args__ = (UniqueConstraint("race_id", "start_index"),)

    id: Mapped[int] = mapped_column(primary_key=True)
    race_id: Mapped[int] = mapped_column(ForeignKey("races.id", ondelete="CASCADE"), index=True)
    model_id: Mapped[int] = mapped_column(ForeignKey("models.id", ondelete="CASCADE"), index=True)
    checkpoint_id: Mapped[int | None] = mapped_column(ForeignKey("checkpoints.id", ondelete="SET NULL"))
    start_index: Mapped[int]  # racecar_<start_index>
    place: Mapped[int]  # 1-based
    status: Mapped[str] = mapped_column(String(16))  # finished | racing
    laps: Mapped[int]
    lap_times: Mapped[list[Any]] = mapped_column(default=list)  # [s] each complete lap
    time: Mapped[float | None]  # [s] race clock at its finish, pauses included
    progress: Mapped[float]  # [%] of the lap it was on at the end
    collisions: Mapped[int] = mapped_column(default=0)
    crashes: Mapped[int] = mapped_column(default=0)  # collisions it was penalised for
    off_track_count: Mapped[int] = mapped_column(default=0)
    penalty_seconds: Mapped[float] = mapped_column(default=0.0)
    trace: Mapped[str | None] = mapped_column(String(1024))  # its evaluation trace folder

    race: Mapped[Race] = relationship(back_populates="entries")
