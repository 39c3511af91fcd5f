"""``drx model create|clone`` with race types: object avoidance and head-to-bot settings."""

from __future__ import annotations

import pytest

from .helpers import fails_unchanged, invoke, ok, ok_json


def _stereo_lidar_car() -> None:
    ok("garage", "add", "sl", "--from", "garage/stereo-lidar.toml")


def test_time_trial_is_the_default() -> None:
    m = ok_json("model", "create", "tt")
    assert m["race"]["race_type"] == "time-trial" and m["race"]["objects"] == 0 and m["race"]["bots"] == 0
    assert "time-trial" in ok("model", "show", "tt").stdout


def test_object_avoidance_settings_are_stored() -> None:
    _stereo_lidar_car()
    m = ok_json("model", "create", "boxes", "--car", "sl", "--race-type", "object-avoidance",
                "--objects", "4", "--randomize-objects")  # fmt: skip
    assert m["race"]["race_type"] == "object-avoidance" and m["race"]["objects"] == 4
    assert m["race"]["randomize_objects"] is True
    placed = ok_json("model", "create", "placed", "--car", "sl", "--race-type", "object-avoidance",
                     "--object-at", "20:inside", "--object-at", "60:outside")  # fmt: skip
    assert placed["race"]["objects"] == 2
    assert placed["race"]["object_positions"] == [[0.2, "inside"], [0.6, "outside"]]
    assert "object-avoidance, 2 boxes (placed)" in ok("model", "show", "placed").stdout


def test_head_to_bot_settings_and_clone_inherits_them() -> None:
    _stereo_lidar_car()
    m = ok_json("model", "create", "bots", "--car", "sl", "--race-type", "head-to-bot", "--bots", "2",
                "--bot-speed", "1.5", "--bot-lane-change", "--randomize-bots")  # fmt: skip
    race = m["race"]
    assert race["randomize_bots"] is True
    assert (race["race_type"], race["bots"], race["bot_speed"], race["bot_lane_change"]) == (
        "head-to-bot", 2, 1.5, True
    )  # fmt: skip
    assert ok_json("model", "clone", "bots", "bots2")["race"] == race
    tt = ok_json("model", "clone", "bots", "bots3", "--race-type", "time-trial")
    assert tt["race"]["race_type"] == "time-trial"


def test_a_car_without_lidar_is_warned_but_allowed() -> None:
    result = invoke("model", "create", "blind", "--race-type", "head-to-bot")
    assert result.exit_code == 0, result.output
    assert "Warning:" in result.stderr and "no lidar" in result.stderr
    assert ok_json("model", "show", "blind")["race"]["bots"] == 3


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (("--race-type", "drag-race"), ("drag-race", "time-trial, object-avoidance, head-to-bot")),
        (("--race-type", "object-avoidance", "--objects", "7"), ("--objects 7", "1-6")),
        (("--race-type", "object-avoidance", "--objects", "0"), ("--objects 0", "1-6")),
        (("--race-type", "object-avoidance", "--object-at", "5:inside"), ("5%", "between 7% and 90%")),
        (("--race-type", "object-avoidance", "--object-at", "20:inside", "--object-at", "25:outside"),
         ("overlap", "13%")),
        (("--race-type", "object-avoidance", "--object-at", "20:middle"), ("middle", "inside or outside")),
        (("--race-type", "object-avoidance", "--object-at", "twenty"), ("twenty", "PLACE:LANE")),
        (("--objects", "3"), ("object-avoidance",)),
        (("--race-type", "head-to-bot", "--bots", "5"), ("--bots 5", "1-4")),
        (("--race-type", "head-to-bot", "--bot-speed", "9"), ("--bot-speed 9", "0.2-6 m/s")),
        (("--race-type", "object-avoidance", "--bots", "2"), ("head-to-bot",)),
        (("--randomize-bots",), ("head-to-bot",)),
    ],
)  # fmt: skip
def test_bad_race_options_exit_2_and_store_nothing(args: tuple[str, ...], words: tuple[str, ...]) -> None:
    fails_unchanged("model", "create", "racer", *args, contains=words)
