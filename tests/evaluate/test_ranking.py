"""Leaderboard ranking on a hand-made set of results, in each mode."""

from __future__ import annotations

from datetime import datetime, timedelta

import pytest

from drx.errors import DrxError, SettingError
from drx.evaluate.ranking import (
    ResultRecord,
    average_lap,
    best_lap,
    laps_from_times,
    rank,
    total_time,
)

T0 = datetime(2026, 1, 1, 12, 0, 0)


def rec(i: int, model: str, times: list[float | None], progress: list[float] | None = None) -> ResultRecord:
    return ResultRecord(
        evaluation_id=i,
        model=model,
        race_laps=3,
        laps=laps_from_times(times, progress),
        created_at=T0 + timedelta(minutes=i),
    )


# Hand-made results of one track (3-lap races).
RESULTS = [
    rec(1, "steady", [10.0, 10.0, 10.0]),  # mean 10, total 30, best 10
    rec(2, "flash", [8.0, 14.0, 13.0]),  # best 8, mean 11.67, total 35
    rec(3, "flash", [9.5, 9.6, None], [100, 100, 40]),  # a later run: best 9.5, no mean, no total
    rec(4, "twolaps", [9.0, 9.2, None], [100, 100, 70]),  # best 9.0 but never 3 laps
    rec(5, "crawler", [None], [62.0]),  # never completed a lap
    rec(6, "lost", [None], [15.0]),
    rec(7, "steady", [11.0, 11.0, 11.0]),  # worse than its own first result
    rec(8, "fivelaps", [12.0, 9.0, 9.0, 9.0, None], [100] * 4 + [50]),  # best window 9.0 over laps 2-4
]


def names(rows: list) -> list[str]:
    return [r.record.model for r in rows]


def test_scores_per_record() -> None:
    assert best_lap(RESULTS[1]) == 8.0
    assert average_lap(RESULTS[1]) == pytest.approx(35.0 / 3)
    assert total_time(RESULTS[1]) == pytest.approx(35.0)
    assert average_lap(RESULTS[2]) is None and total_time(RESULTS[2]) is None
    assert average_lap(RESULTS[7]) == pytest.approx(9.0)  # consecutive window, not the first three laps
    assert total_time(RESULTS[7]) == pytest.approx(30.0)  # the race's three laps
    assert best_lap(RESULTS[4]) is None


def test_rank_best_lap() -> None:
    rows = rank(RESULTS, "best-lap")
    assert names(rows) == ["flash", "twolaps", "fivelaps", "steady", "crawler", "lost"]
    assert [r.rank for r in rows] == [1, 2, 3, 4, 5, 6]
    assert rows[0].score == 8.0 and rows[0].record.evaluation_id == 2
    assert rows[3].record.evaluation_id == 1  # steady's better result
    assert rows[4].score is None and rows[4].record.progress == 62.0


def test_rank_average_lap() -> None:
    rows = rank(RESULTS, "average-lap")
    # scored: fivelaps 9.0, steady 10.0, flash 11.67 (run 2); then lap-completers without a
    # 3-lap window: twolaps (2 laps, best 9.0); then never-completed by progress
    assert names(rows) == ["fivelaps", "steady", "flash", "twolaps", "crawler", "lost"]
    assert rows[2].record.evaluation_id == 2
    assert rows[2].score == pytest.approx(35.0 / 3)
    assert rows[3].score is None


def test_rank_total_time() -> None:
    rows = rank(RESULTS, "total-time")
    assert names(rows) == ["steady", "fivelaps", "flash", "twolaps", "crawler", "lost"]
    assert [r.score for r in rows[:3]] == [pytest.approx(30.0), pytest.approx(30.0), pytest.approx(35.0)]
    # steady and fivelaps tie on 30 s: the earlier result goes first
    assert rows[0].record.created_at < rows[1].record.created_at


def test_models_without_a_lap_rank_below_by_progress() -> None:
    rows = rank([rec(1, "a", [None], [10.0]), rec(2, "b", [None], [80.0]), rec(3, "c", [30.0, None, None])])
    assert names(rows) == ["c", "b", "a"]


def test_unknown_mode_is_refused() -> None:
    with pytest.raises(SettingError, match="^rank 'fastest' is unknown; use one of best-lap") as info:
        rank(RESULTS, "fastest")
    assert info.value.field == "rank"
    with pytest.raises(DrxError, match="^rank"):
        rank(RESULTS, "fastest")


def test_empty() -> None:
    assert rank([], "total-time") == []


def test_a_minimum_lap_count_qualifies_results() -> None:
    """Rules with min_laps rank only results with that many complete laps in a row (DeepRacer on
    AWS's minimumLaps); the others follow without a place, and average-lap averages min_laps laps."""
    five = [
        ResultRecord(1, "steady", 5, laps_from_times([9.0, 9.0, 9.0, 9.0, 9.0]), T0, min_laps=3),
        ResultRecord(2, "quick", 5, laps_from_times([8.0, 8.5, 8.0, None], [100] * 3 + [20]), T0, min_laps=3),
        ResultRecord(3, "short", 5, laps_from_times([7.0, 7.0, None], [100, 100, 50]), T0, min_laps=3),
        ResultRecord(4, "short", 5, laps_from_times([11.0] * 5), T0 + timedelta(minutes=1), min_laps=3),
        ResultRecord(5, "gone", 5, laps_from_times([6.0, None], [100, 10]), T0, min_laps=3),
    ]
    rows = rank(five, "best-lap")
    assert [(r.rank, r.record.model, r.record.evaluation_id) for r in rows] == [
        (1, "quick", 2), (2, "steady", 1), (3, "short", 4), (None, "gone", 5)]  # fmt: skip
    assert rows[3].score == 6.0  # its time is shown; it has no place
    assert average_lap(five[1]) == pytest.approx(24.5 / 3)  # 3 laps of 4, though the race has 5
    assert [r.record.model for r in rank(five, "average-lap")][:2] == ["quick", "steady"]
    assert rank(five, "total-time")[0].record.model == "steady"  # quick never drove all 5 laps
    assert not five[2].qualified and five[2].consecutive_laps == 2 and five[1].window == 3
