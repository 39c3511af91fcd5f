"""Race rules on the leaderboard (issue 33, item 4): one board per set of rules, the minimum lap
count to qualify, the rules said with every board, old rows, and bad rule input.

Evaluations are written straight into the registry (no simulation) except one ``drx evaluate``
run, so the file runs in seconds.
"""

from __future__ import annotations

from datetime import UTC, datetime, timedelta
from typing import Any

import pytest

from drx.evaluate.leaderboard import leaderboard
from drx.evaluate.service import EvaluationRequest
from drx.evaluate.time_trial import RaceRules
from drx.registry import Evaluation, EvaluationLap, session_scope
from drx.services import models as model_service
from drx.settings.race import RaceConfig

from ._cli import drx, drx_json, fails_unchanged
from ._models import model_with_checkpoint

T0 = datetime(2026, 3, 1, 12, tzinfo=UTC)
THREE = RaceRules(laps=3)
FIVE_MIN3 = RaceRules(laps=5, min_laps=3)


def _models(*names: str) -> None:
    for name in names:
        model_service.create_model(name)


def _result(model: str, times: list[float | None], rules: RaceRules | dict[str, Any], minute: int,
            track: str = "oval") -> int:  # fmt: skip
    """Store a complete evaluation of ``model`` with these lap times (``None``: a lap cut short)
    under ``rules`` (a dict: stored as it is, as older drx versions stored it)."""
    stored = rules.to_dict() if isinstance(rules, RaceRules) else dict(rules)
    stored.update(car="default", action_space="10 actions", best_lap=7.0)
    with session_scope() as session:
        ev = Evaluation(
            model_id=model_service.get_model(model).id,
            track_name=track,
            rules=stored,
            status="complete",
            laps_completed=sum(t is not None for t in times),
            created_at=T0 + timedelta(minutes=minute),
        )
        ev.laps = [
            EvaluationLap(lap=i + 1, time=t, progress=100.0 if t is not None else 40.0,
                          status="lap_complete" if t is not None else "off_track")
            for i, t in enumerate(times)
        ]  # fmt: skip
        session.add(ev)
        session.flush()
        return int(ev.id)


def _ids(board: dict[str, Any]) -> list[int]:
    return [row["evaluation"] for row in board["rows"]]


def test_results_of_different_rules_are_never_ranked_together() -> None:
    """Each set of rules is its own board; the default is the latest evaluation's; the options each
    board names for the others show exactly those boards."""
    _models("a", "b", "c")
    three_a = _result("a", [9.0, 9.0, 9.0], THREE, 1)
    three_b = _result("b", [8.0, 8.0, 8.0], THREE, 2)
    penalty_a = _result("a", [7.0, 7.0, 7.0], RaceRules(laps=3, off_track_penalty=5.0), 3)  # fastest, apart
    reverse_c = _result("c", [6.0, 6.0, 6.0], RaceRules(laps=3, direction="reverse"), 4)
    boxes_c = _result(
        "c", [5.0, 5.0, 5.0], RaceRules(laps=3, race=RaceConfig("object-avoidance", objects=2)), 5
    )
    five_b = _result("b", [9.5, 9.5, 9.5, 9.5, 9.5], FIVE_MIN3, 6)
    five_c = _result("c", [9.9, 9.9, 9.9, 9.9, 9.9], FIVE_MIN3, 7)

    default = leaderboard("oval")
    assert _ids(default) == [five_b, five_c]  # the rules of the latest evaluation
    assert default["rules"]["laps"] == 5 and default["rules"]["min_laps"] == 3
    assert (
        default["rules"]["text"]
        == "time-trial, ccw, 5 laps (min 3 to qualify), off-track 2 s, no reset limit"
    )
    assert _ids(leaderboard("oval", filters={"laps": 3, "off_track_penalty": 2.0}, race_type="time-trial",
                            direction="default")) == [three_b, three_a]  # fmt: skip
    assert _ids(leaderboard("oval", filters={"off_track_penalty": 5.0})) == [penalty_a]
    assert _ids(leaderboard("oval", direction="reverse")) == [reverse_c]
    assert _ids(leaderboard("oval", race_type="object-avoidance")) == [boxes_c]
    assert _ids(leaderboard("oval", rules_of=three_a)) == [three_b, three_a]
    # every evaluation is on exactly one board, and each board's options show that board
    seen = set(_ids(default))
    for other in default["other_rules"]:
        board = drx_json("leaderboard", "--track", "oval", *other["options"].split())
        assert board["rules"] == other["rules"], other
        assert not seen & set(_ids(board))
        seen |= set(_ids(board))
    assert seen == {three_a, three_b, penalty_a, reverse_c, boxes_c, five_b, five_c}
    # without --track: the track of the latest evaluation that has the rules asked for
    _models("d")
    elsewhere = _result("d", [20.0, 20.0, 20.0], THREE, 8, track="Oval_track")
    assert leaderboard()["track"] == "Oval_track" and _ids(leaderboard()) == [elsewhere]
    assert leaderboard(filters={"laps": 5})["track"] == "oval"


def test_min_laps_qualifies_results_and_ranks_the_rest_below() -> None:
    _models("steady", "quick", "short", "crawler")
    _result("steady", [9.6, 9.5, 9.4, 9.5, 9.6], FIVE_MIN3, 1)
    qualified = _result("quick", [8.9, 9.0, 9.1, None], FIVE_MIN3, 2)  # 3 in a row: qualifies
    _result("short", [7.0, 7.1, None], FIVE_MIN3, 3)  # fastest lap, but only 2 laps: DNQ
    _result("crawler", [None], FIVE_MIN3, 4)
    _result("short", [12.0, 12.0, 12.0, 12.0, 12.0], FIVE_MIN3, 5)  # short's slower, qualified result
    board = leaderboard("oval")
    rows = [(r["rank"], r["model"], r["qualified"]) for r in board["rows"]]
    assert rows == [(1, "quick", True), (2, "steady", True), (3, "short", True), (None, "crawler", False)]
    assert board["rows"][0]["evaluation"] == qualified
    assert board["rows"][3]["note"] == "did not qualify: 0 complete laps in a row, the rules ask for 3"
    # average-lap averages 3 consecutive laps (the minimum), so a 4-lap result has its score
    average = leaderboard("oval", "average-lap")
    assert average["rows"][0]["model"] == "quick" and average["rows"][0]["score"] == pytest.approx(9.0)
    # the DNQ result of a model with no qualified one is listed below, unranked, and says why
    _models("lone")
    _result("lone", [6.0, None], FIVE_MIN3, 6)
    last = leaderboard("oval")["rows"][-2:]
    assert [(r["model"], r["rank"]) for r in last] == [("lone", None), ("crawler", None)]
    out = drx("leaderboard", "--track", "oval").stdout
    assert "DNQ" in out and "fewer than 3 complete laps in a row" in out


def test_old_rows_without_a_rule_take_its_default() -> None:
    """Rows stored before min_laps (or races, or directions) rank with new rows of the same rules."""
    _models("old", "older", "new")
    old = _result("old", [9.0, 9.0, 9.0], {"laps": 3, "off_track_penalty": 2.0, "max_resets": None,
                                           "time_cap_minutes": 20.0, "direction": "default"}, 1)  # fmt: skip
    older = _result("older", [9.5, 9.5, 9.5], {"laps": 3}, 2)
    new = _result("new", [8.0, 8.0, None], THREE, 3)
    board = leaderboard("oval")
    assert _ids(board) == [new, old, older] and board["other_rules"] == []
    assert board["rules"]["min_laps"] is None and board["rules"]["race_type"] == "time-trial"
    assert all(r["qualified"] for r in board["rows"])
    # a collision penalty cannot matter in a time trial: it does not split the board
    _models("calm")
    calm = _result("calm", [8.5, 8.5, 8.5], RaceRules(laps=3, collision_penalty=1.0), 4)
    assert _ids(leaderboard("oval")) == [new, calm, old, older]
    shown = drx_json("eval", "show", old)
    assert shown["rules"]["min_laps"] is None and shown["qualified"] is True


def test_json_names_the_rules_and_the_other_boards() -> None:
    _models("a", "b")
    _result("a", [9.0, 9.0, 9.0], THREE, 1)
    five = _result("b", [9.0, None], FIVE_MIN3, 2)
    board = drx_json("leaderboard", "--track", "oval")
    assert set(board) == {"track", "rank", "direction", "race_type", "rules", "rows", "other_rules"}
    assert {k: board["rules"][k] for k in ("laps", "min_laps", "off_track_penalty", "max_resets", "direction",
                                           "race_type", "collision_penalty")} == {
        "laps": 5, "min_laps": 3, "off_track_penalty": 2.0, "max_resets": None, "direction": "default",
        "race_type": "time-trial", "collision_penalty": None}  # fmt: skip
    (row,) = board["rows"]
    assert (row["evaluation"], row["rank"], row["qualified"]) == (five, None, False)
    (other,) = board["other_rules"]
    assert other["rules"]["laps"] == 3 and other["models"] == 1 and other["options"] == "--laps 3"
    assert other["differs"] == "3 laps, no minimum laps"
    every = ("--laps", "3", "--min-laps", "none", "--no-reverse", "--race-type", "time_trial",
             "--max-resets", "none", "--off-track-penalty", "2", "--time-cap-minutes", "20")  # fmt: skip
    again = drx_json("leaderboard", "--track", "oval", *every)
    assert again["rules"]["laps"] == 3 and [r["model"] for r in again["rows"]] == ["a"]
    nothing = drx_json("leaderboard", "--track", "oval", "--laps", "7")
    assert nothing["rows"] == [] and nothing["rules"] is None and len(nothing["other_rules"]) == 2
    assert "No results on oval under --laps 7" in drx("leaderboard", "--track", "oval", "--laps", "7").stdout


def test_the_board_fits_80_columns(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("COLUMNS", "80")
    name = "demo-20261122-173900-long-name"
    _models(name, "b")
    _result(name, [9.0, 9.0, 9.0], RaceRules(laps=3, direction="reverse", max_resets=2), 1)
    _result("b", [10.0, 10.0, 10.0], RaceRules(laps=3, race=RaceConfig("object-avoidance", objects=2)), 2)
    _result(name, [9.0, None, None, None, None], FIVE_MIN3, 3)
    out = drx("leaderboard").stdout
    assert max(len(line) for line in out.splitlines()) <= 80, out
    assert "Rules: time-trial, ccw, 5 laps (min 3 to qualify)" in out and name in out and "DNQ" in out
    assert "drx leaderboard --track oval --reverse" in out, out


def test_bad_rule_input_exits_2_and_stores_nothing() -> None:
    _models("m")
    _result("m", [9.0, 9.0, 9.0], THREE, 1)
    for args, says in [
        (("--min-laps", "-1"), "--min-laps -1 is invalid; use a whole number from 1 to 3"),
        (("--min-laps", "2.5"), "--min-laps '2.5' is not a whole number"),
        (("--min-laps", "4"), "--min-laps 4 is more than the race's --laps 3; use --min-laps 3 or fewer"),
        (("--laps", "5", "--min-laps", "6"), "--min-laps 6 is more than the race's --laps 5"),
    ]:
        fails_unchanged("evaluate", "m", *args, contains=says)
    for args, says in [
        (("--min-laps", "-1"), "--min-laps -1 is out of range; use 1 to 100, or none"),
        (("--min-laps", "two"), "--min-laps 'two' is not a whole number"),
        (("--laps", "3", "--min-laps", "4"), "--min-laps 4 is more than --laps 3"),
        (("--laps", "2.5"), "--laps '2.5' is not a whole number"),
        (("--max-resets", "lots"), "--max-resets 'lots' is not a whole number"),
        (("--max-resets", "-2"), "--max-resets -2 is invalid; use 0 or more, or none"),
        (("--off-track-penalty", "soft"), "--off-track-penalty 'soft' is not a number"),
        (("--race-type", "drag"), "--race-type drag is unknown"),
        (("--rules-of", "99"), "No complete evaluation 99"),
        (
            ("--rules-of", "1", "--laps", "3"),
            "--rules-of 1 takes every rule from that evaluation; leave out --laps",
        ),
    ]:
        fails_unchanged("leaderboard", *args, contains=says)


def test_evaluate_stores_min_laps_and_says_whether_the_result_qualified() -> None:
    model_with_checkpoint("racer")
    data = drx_json("evaluate", "racer", "--laps", "2", "--min-laps", "2", "--max-resets", "0",
                    "--time-cap-minutes", "0.3", "--seed", "1")  # fmt: skip
    assert data["rules"]["min_laps"] == 2
    assert data["qualified"] is (data["laps_completed"] >= 2)
    board = drx_json("leaderboard", "--track", "oval")
    assert board["rules"]["min_laps"] == 2 and board["rows"][0]["qualified"] is data["qualified"]
    assert "2 in a row to qualify" in drx("eval", "show", data["id"]).stdout
    request = EvaluationRequest(model="racer", laps=3, min_laps=1)  # what a queued job keeps
    assert EvaluationRequest.from_options(request.to_options()).min_laps == 1
