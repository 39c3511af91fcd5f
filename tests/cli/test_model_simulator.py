"""``--simulator 5|6`` and ``--car-randomization`` on ``drx model create|clone``, ``drx evaluate`` and
``drx track best-lap``; the car in ``drx model show`` and ``drx info``; bad values refused with
nothing stored."""

from __future__ import annotations

from .helpers import fails_unchanged, ok, ok_json


def test_new_models_race_on_simulator_6_and_clones_inherit_the_car() -> None:
    made = ok_json("model", "create", "venue")
    assert made["simulator"] == "6" and made["car_randomization"] is False
    assert made["vehicle"]["version"] == "6"  # its model_metadata.json names the car it trains on
    assert ok_json("model", "create", "console", "--simulator", "5")["simulator"] == "5"
    assert ok_json("model", "create", "either", "--car-randomization")["car_randomization"] is True
    kid = ok_json("model", "clone", "console", "kid")
    assert kid["simulator"] == "5" and kid["car_randomization"] is False  # the parent's
    moved = ok_json("model", "clone", "console", "moved", "--simulator", "6.0", "--car-randomization")
    assert moved["simulator"] == "6" and moved["car_randomization"] is True
    plain = ok_json("model", "clone", "either", "plain", "--no-car-randomization")
    assert plain["car_randomization"] is False
    shown = ok("model", "show", "console").stdout
    assert "DeepRacer simulator 5 (the console" in shown
    assert "between 5's and 6's" in ok("model", "show", "either").stdout


def test_an_unknown_simulator_is_refused_and_nothing_is_stored() -> None:
    for bad in ("7", "4", "five"):
        fails_unchanged(
            "model", "create", "m", "--simulator", bad,
            contains=(f"--simulator {bad!r} is not a DeepRacer simulator drx has a car for", "use 5"),
        )  # fmt: skip
    ok("model", "create", "m")
    fails_unchanged("model", "clone", "m", "kid", "--simulator", "3", contains="--simulator '3'")
    fails_unchanged("track", "best-lap", "oval", "--simulator", "9", contains="--simulator '9'")


def test_best_lap_names_the_car_and_the_cars_differ() -> None:
    six = ok_json("track", "best-lap", "oval")
    five = ok_json("track", "best-lap", "oval", "--simulator", "5")
    assert six["simulator"] == "6" and five["simulator"] == "5"
    assert six["lap_time"] != five["lap_time"]  # two cars, two limits
    assert "simulator 6" in ok("track", "best-lap", "oval").stdout


def test_info_says_which_car_new_models_get() -> None:
    data = ok_json("info")
    assert data["simulator"] == {"new_models": "6", "cars": ["5", "6"]}
    assert "simulator 6's car" in ok("info").stdout



def test_evaluate_refuses_an_unknown_simulator_before_anything_is_queued() -> None:
    """Checked before the model's checkpoint (it has none), and before a detached job is queued."""
    ok("model", "create", "m")
    for detach in ((), ("--detach",)):
        fails_unchanged("evaluate", "m", "--simulator", "9", *detach, contains="--simulator '9' is not")
    assert ok_json("jobs", "list") == []
