"""Leaderboard ranking: pure functions on evaluation records.

Three modes, as on DeepRacer's leaderboards (``../shared/DEEPRACER.md`` section 5):

* ``best-lap``: the fastest complete lap of a result (penalties included).
* ``average-lap``: the best mean over N *consecutive* complete laps, N being
  the race's minimum laps when its rules set one (DeepRacer on AWS averages
  ``minimumLaps`` consecutive laps), else the race's laps (so a 3-lap race
  scores the mean of its 3 laps, and only when all 3 were completed).
* ``total-time``: the time of all the race's laps, when all were completed.

**Qualifying.** Rules with a minimum lap count (``min_laps``) admit a result
only with at least that many complete laps in a row, as DeepRacer on AWS ranks
a submission only when its longest run of consecutive complete laps reaches the
race's ``minimumLaps``. A result that falls short does not qualify: it gets no
place, and lists below every qualified result.

Each model gets one row: its best result under the mode. Rows are ordered in
tiers: first the results with a score (fastest first); then results that
completed a lap but have no score under this mode (more laps first, then
their best lap); last the models that never completed a lap, by progress
(the furthest any of their laps got). Results that did not qualify follow in
the same order. Ties go to the earlier result.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from datetime import datetime
from typing import Any

from drx.errors import SettingError

MODES = ("best-lap", "average-lap", "total-time")


@dataclass(frozen=True)
class LapRecord:
    """One lap of a stored result.

    :param time: [s] the lap's time when complete, else ``None``.
    :param progress: [%] of the lap driven.
    """

    time: float | None
    progress: float = 100.0


@dataclass(frozen=True)
class ResultRecord:
    """One evaluation, as the leaderboard sees it.

    :param evaluation_id: the evaluation's id.
    :param model: the model's name.
    :param race_laps: the laps the race asked for (N).
    :param laps: every lap driven, in order.
    :param created_at: when it ran.
    :param off_track_count: off-tracks over the whole result.
    :param extra: anything to carry through to the row (car, action space, track...).
    :param min_laps: complete laps in a row the result needs to qualify; ``None``: no minimum.
    """

    evaluation_id: int
    model: str
    race_laps: int
    laps: tuple[LapRecord, ...]
    created_at: datetime
    off_track_count: int = 0
    extra: dict[str, Any] = field(default_factory=dict)
    min_laps: int | None = None

    @property
    def complete_times(self) -> list[float]:
        """Times of the complete laps."""
        return [lap.time for lap in self.laps if lap.time is not None]

    @property
    def progress(self) -> float:
        """[%] the furthest a lap got."""
        return max((lap.progress for lap in self.laps), default=0.0)

    @property
    def consecutive_laps(self) -> int:
        """The longest run of complete laps in a row (in drx's trials every complete lap is in it:
        a lap ends incomplete only when the trial ends)."""
        return longest_run(lap.time is not None for lap in self.laps)

    @property
    def qualified(self) -> bool:
        """Whether the result meets its rules' minimum lap count (always, without one)."""
        return self.min_laps is None or self.consecutive_laps >= self.min_laps

    @property
    def window(self) -> int:
        """N, the consecutive laps ``average-lap`` averages: the minimum when the rules set one."""
        return self.min_laps or self.race_laps


def longest_run(complete: Iterable[bool]) -> int:
    """The longest run of ``True`` in ``complete`` (laps complete in a row)."""
    best = run = 0
    for done in complete:
        run = run + 1 if done else 0
        best = max(best, run)
    return best


@dataclass(frozen=True)
class LeaderboardRow:
    """A model's place on the leaderboard.

    :param rank: 1-based place; ``None`` for a result that did not qualify (no place).
    :param record: the model's result that earned it.
    :param score: [s] the mode's score, or ``None`` (no score under this mode).
    """

    rank: int | None
    record: ResultRecord
    score: float | None


def best_lap(record: ResultRecord) -> float | None:
    """[s] the fastest complete lap, or ``None``."""
    times = record.complete_times
    return min(times) if times else None


def average_lap(record: ResultRecord) -> float | None:
    """[s] the best mean over :attr:`ResultRecord.window` consecutive complete laps, or ``None``."""
    n = record.window
    times = [lap.time for lap in record.laps]
    best: float | None = None
    for start in range(0, len(times) - n + 1):
        window = times[start : start + n]
        if all(t is not None for t in window):
            mean = sum(window) / n  # type: ignore[arg-type]
            best = mean if best is None else min(best, mean)
    return best


def total_time(record: ResultRecord) -> float | None:
    """[s] the time of the race's laps when every one was completed, else ``None``."""
    times = [lap.time for lap in record.laps[: record.race_laps]]
    if len(times) < record.race_laps or any(t is None for t in times):
        return None
    return sum(times)  # type: ignore[arg-type]


SCORES = {"best-lap": best_lap, "average-lap": average_lap, "total-time": total_time}


def score(record: ResultRecord, mode: str) -> float | None:
    """The score [s] of ``record`` under ``mode`` (lower is better), or ``None``."""
    check_mode(mode)
    return SCORES[mode](record)


def check_mode(mode: str) -> None:
    """Raise :class:`DrxError` unless ``mode`` is a ranking mode."""
    if mode not in MODES:
        raise SettingError(
            "{field} {value!r} is unknown; use one of {allowed}.",
            "rank",
            value=mode,
            allowed=", ".join(MODES),
        )


def sort_key(record: ResultRecord, mode: str) -> tuple[Any, ...]:
    """The ordering of results under ``mode`` (smaller is better): qualified results first."""
    value = score(record, mode)
    when = record.created_at.timestamp()
    out = 0 if record.qualified else 1
    if value is not None:
        return (out, 0, value, when, record.evaluation_id)
    done = record.complete_times
    if done:
        return (out, 1, -len(done), min(done), when, record.evaluation_id)
    return (out, 2, -record.progress, when, record.evaluation_id)


def rank(records: Iterable[ResultRecord], mode: str = "best-lap") -> list[LeaderboardRow]:
    """One row per model, its best result under ``mode``, in leaderboard order.

    Qualified results take places 1, 2, ...; results that did not qualify follow without one.

    :param records: results of any number of models, of one track and one set of rules (results
        of other rules are not comparable: :mod:`drx.evaluate.leaderboard` keeps them apart).
    :param mode: ``best-lap``, ``average-lap`` or ``total-time``.
    """
    check_mode(mode)
    best: dict[str, ResultRecord] = {}
    for rec in records:
        held = best.get(rec.model)
        if held is None or sort_key(rec, mode) < sort_key(held, mode):
            best[rec.model] = rec
    ordered = sorted(best.values(), key=lambda r: sort_key(r, mode))
    places = sum(1 for r in ordered if r.qualified)  # qualified results sort first
    return [
        LeaderboardRow(rank=i + 1 if i < places else None, record=r, score=score(r, mode))
        for i, r in enumerate(ordered)
    ]


def laps_from_times(
    times: Sequence[float | None], progress: Sequence[float] | None = None
) -> tuple[LapRecord, ...]:
    """Lap records from lap times (``None`` = incomplete) and optional progress values."""
    prog = list(progress) if progress is not None else [100.0 if t is not None else 0.0 for t in times]
    return tuple(LapRecord(time=t, progress=p) for t, p in zip(times, prog, strict=True))
