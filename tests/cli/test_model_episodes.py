"""``drx model create|clone --direction``, the start options and several ``--track``: resolved
once, stored, shown, inherited, trained as asked, evaluated and exported; bad input refused."""

from __future__ import annotations

from typing import Any

import pytest

from .helpers import fails_unchanged, ok, ok_json


def _tracks(m: dict[str, Any]) -> list[tuple[str, str | None, bool]]:
    return [(t["name"], t["direction"], t["reverse"]) for t in m["tracks"]]


@pytest.mark.parametrize(
    ("track", "direction", "route", "reverse"),
    [
        ("A to Z Speedway", "cw", "reInvent2019_wide_cw", False),  # the console: a track and a direction
        ("A to Z Speedway", "counter-clockwise", "reInvent2019_wide_ccw", False),
        ("reInvent2019_wide", "Clockwise", "reInvent2019_wide_cw", False),
        ("reInvent2019_wide_cw", "ccw", "reInvent2019_wide_ccw", False),  # the direction names the route
        ("Forever Raceway", "cw", "2024_reinvent_champ_cw", False),  # refused without a direction
        ("reinvent_base", "clockwise", "reinvent_base", True),  # one-way: driven reversed
        ("reinvent_base", "ccw", "reinvent_base", False),  # its own way
    ],
)
def test_a_direction_resolves_to_the_route_that_drives_it(
    track: str, direction: str, route: str, reverse: bool
) -> None:
    m = ok_json("model", "create", "m", "--track", track, "--direction", direction)
    expected = "ccw" if direction.lower().startswith(("ccw", "counter")) else "cw"
    assert (m["track"], m["direction"], _tracks(m)) == (route, expected, [(route, expected, reverse)])
    shown = ok("model", "show", "m").stdout
    assert ("counter-clockwise" if expected == "ccw" else "clockwise") in shown
    assert ("(reversed)" in shown) is reverse


def test_route_ids_and_display_names_keep_working_without_a_direction() -> None:
    assert ok_json("model", "create", "a", "--track", "reInvent2019_wide_cw")["direction"] == "cw"
    b = ok_json("model", "create", "b", "--track", "A to Z Speedway (counter-clockwise)")
    assert (b["track"], b["direction"]) == ("reInvent2019_wide_ccw", "ccw")
    straight = ok_json("model", "create", "s", "--track", "Straight_track")
    assert straight["direction"] is None and _tracks(straight) == [("Straight_track", "-", False)]


def test_start_options_are_stored_shown_and_inherited() -> None:
    m = ok_json("model", "create", "m")
    assert m["training_options"] == {
        "alternate_direction": False,
        "change_start_position": True,
        "round_robin_advance": 0.05,
        "start_position_offset": 0.0,
        "direction_asked": None,
    }  # DeepRacer's defaults
    m = ok_json("model", "create", "rr", "--alternate-direction", "--round-robin-advance", "0.1",
                "--start-position-offset", "0.25")  # fmt: skip
    options = m["training_options"]
    assert options["alternate_direction"] is True
    assert (options["round_robin_advance"], options["start_position_offset"]) == (0.1, 0.25)
    shown = ok("model", "show", "rr").stdout
    assert "episode starts" in shown and "+10% of the lap" in shown and "alternating" in shown
    kid = ok_json("model", "clone", "rr", "kid")
    assert kid["training_options"] == m["training_options"] and kid["track"] == "oval"  # all of it inherited
    fixed = ok_json("model", "clone", "rr", "fixed", "--no-change-start-position",
                    "--no-alternate-direction")["training_options"]  # fmt: skip
    assert fixed["change_start_position"] is False and fixed["alternate_direction"] is False
    assert fixed["start_position_offset"] == 0.25
    assert "every episode at 25%" in ok("model", "show", "fixed").stdout


def test_a_clone_keeps_or_turns_its_parents_tracks() -> None:
    ok("model", "create", "p", "--track", "reinvent_base", "--track", "A to Z Speedway", "--direction", "cw")
    parent = ok_json("model", "show", "p")
    assert _tracks(parent) == [("reinvent_base", "cw", True), ("reInvent2019_wide_cw", "cw", False)]
    assert _tracks(ok_json("model", "clone", "p", "same")) == _tracks(parent)
    turned = ok_json("model", "clone", "p", "turned", "--direction", "ccw")
    assert _tracks(turned) == [("reinvent_base", "ccw", False), ("reInvent2019_wide_ccw", "ccw", False)]
    # new tracks: their own way unless a direction comes with them (the console asks anew)
    assert _tracks(ok_json("model", "clone", "p", "new", "--track", "oval")) == [("oval", "ccw", False)]
    assert _tracks(ok_json("model", "clone", "p", "new-cw", "--track", "oval", "--direction", "cw")) == [
        ("oval", "cw", True)
    ]


def test_several_tracks_are_stored_in_order_and_shown() -> None:
    m = ok_json("model", "create", "multi", "--track", "oval", "--track", "A to Z Speedway (clockwise)",
                "--track", "kidney")  # fmt: skip
    assert m["track"] == "oval"  # the first: the model's track for evaluation
    assert [t["name"] for t in m["tracks"]] == ["oval", "reInvent2019_wide_cw", "kidney"]
    shown = ok("model", "show", "multi").stdout
    assert "tracks" in shown and "episodes take the tracks in turn" in shown and "Training per track" in shown
    assert [r["track"] for r in ok_json("model", "show", "multi")["track_figures"]] == [
        "oval", "reInvent2019_wide_cw", "kidney"
    ]  # fmt: skip


@pytest.mark.parametrize(
    ("args", "sentence"),
    [
        (("--direction", "up"), ("--direction 'up' is unknown", "cw (clockwise) or ccw")),
        (("--track", "Straight_track", "--direction", "cw"),
         ("'Straight_track' is open", "leave out --direction")),
        (("--track", "Straight_track", "--alternate-direction"),
         ("--alternate-direction needs a loop", "Straight")),
        (("--round-robin-advance", "0"), ("--round-robin-advance 0.0 is out of range", "between 0 and 1")),
        (("--round-robin-advance", "1.5"), ("--round-robin-advance 1.5 is out of range",)),
        (("--start-position-offset", "1"), ("--start-position-offset 1.0 is out of range",)),
        (("--start-position-offset", "-0.2"), ("--start-position-offset -0.2 is out of range",)),
        (("--no-change-start-position", "--round-robin-advance", "0.1"),
         ("--round-robin-advance 0.1 does nothing while --change-start-position is off",)),
        (("--track", "Straight_track", "--track", "oval"),
         ("'Straight_track' is open and 'oval' is a loop",)),
        (("--track", "oval", "--track", "kidney", "--track", "oval"), ("--track 'oval' is given twice",)),
        (("--track", "A to Z Speedway", "--track", "reInvent2019_wide"),
         ("'A to Z Speedway' and 'reInvent2019_wide' are both reInvent2019_wide",)),
        (("--track", "oval", "--track", "nowhere"), ("No track named 'nowhere'",)),
    ],
)  # fmt: skip
def test_bad_input_is_one_sentence_and_stores_nothing(
    args: tuple[str, ...], sentence: tuple[str, ...]
) -> None:
    fails_unchanged("model", "create", "m", *args, contains=sentence)


def test_a_clone_refuses_what_does_not_fit_its_inherited_options() -> None:
    ok("model", "create", "p", "--alternate-direction")
    fails_unchanged("model", "clone", "p", "k", "--track", "Straight_track", contains="--alternate-direction")
    fails_unchanged("model", "clone", "p", "k", "--direction", "sideways", contains="--direction 'sideways'")
    assert ok_json("model", "clone", "p", "k", "--track", "Straight_track", "--no-alternate-direction")


def test_training_drives_the_tracks_in_turn_and_keeps_them_apart() -> None:
    """A two-track model trained through the queue: its episode rows name their track, `model show`
    gives each track's figures, and the trainer's evaluation and the model's default evaluation
    drive the first track the way it trains (reversed here). (The per-iteration line and the
    dashboard: tests/cli/test_progress.py.)"""
    from sqlalchemy import select

    from drx.evaluate.service import EvaluationRequest, prepare
    from drx.queue import lifecycle
    from drx.queue.dispatch import run_job
    from drx.registry import Episode, session_scope

    ok("model", "create", "two", "--track", "oval", "--track", "kidney", "--direction", "cw",
       "--network", "compact", "--max-episodes", "6", "--episodes-per-iteration", "6",
       "--rollout-workers", "1")  # fmt: skip
    job = lifecycle.enqueue_training("two", {"eval_episodes": 1})
    assert run_job(job.id).status == "succeeded"
    with session_scope() as session:
        rows = list(session.execute(
            select(Episode.phase, Episode.track_name, Episode.start_fraction).order_by(Episode.id)
        ))  # fmt: skip
    training = [(track, round(start, 4)) for phase, track, start in rows if phase == "training"]
    assert training == [("oval", 0.0), ("kidney", 0.0), ("oval", 0.05), ("kidney", 0.05),
                        ("oval", 0.1), ("kidney", 0.1)]  # fmt: skip
    assert {track for phase, track, _ in rows if phase == "evaluation"} == {None}
    figures = ok_json("model", "show", "two")["track_figures"]
    assert [(f["track"], f["episodes"], f["iteration"]) for f in figures] == [
        ("oval", 3, 0), ("kidney", 3, 0)
    ]  # fmt: skip
    assert "Training per track" in ok("model", "show", "two").stdout
    prepared = prepare(EvaluationRequest("two"))
    assert prepared.rules.direction == "reverse" and prepared.track.direction == "cw"
