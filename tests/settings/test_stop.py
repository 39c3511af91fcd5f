"""Stop conditions: defaults, a user's overrides (checked), the stored JSON and the job's overrides."""

from __future__ import annotations

import dataclasses

import pytest

from drx.errors import SettingError
from drx.settings.stop import STOP_KEYS, StopConditions


def test_one_definition_of_the_keys() -> None:
    assert STOP_KEYS == ("max_minutes", "max_steps", "max_episodes", "target_iterations")
    assert tuple(f.name for f in dataclasses.fields(StopConditions)) == STOP_KEYS


def test_defaults_overrides_and_json() -> None:
    stop = StopConditions()
    assert stop.to_dict() == {
        "max_minutes": 60,
        "max_steps": None,
        "max_episodes": None,
        "target_iterations": None,
    }
    stop = stop.overridden(
        {"max_minutes": 2, "target_iterations": 3, "max_steps": 5000, "max_episodes": None}
    )
    assert stop.describe() == "2 min, 5000 steps, 3 full-lap iterations in a row"
    again = StopConditions.from_dict(stop.to_dict()).overridden({"max_episodes": 7})
    assert (again.max_minutes, again.max_steps, again.max_episodes) == (2, 5000, 7)
    assert StopConditions.from_dict({}).max_minutes == 60  # a missing key is the default
    assert StopConditions.from_dict({"max_minutes": None}).describe() == "no time limit"


def test_stored_values_are_taken_as_they_are() -> None:
    # tests train for seconds: a stored 0.05 minutes is not a user's value, so it is not checked
    assert StopConditions.from_dict({"max_minutes": 0.05}).max_minutes == 0.05


@pytest.mark.parametrize(
    ("overrides", "sentence"),
    [
        ({"max_minutes": 0.5}, "max_minutes 0.5 is out of range; use 1 to 1440 minutes"),
        ({"max_minutes": 1441}, "max_minutes 1441 is out of range; use 1 to 1440 minutes"),
        ({"max_minutes": float("nan")}, "max_minutes nan is out of range"),
        ({"max_steps": 0}, "max_steps 0 is out of range; use a whole number of at least 1."),
        ({"max_episodes": -3}, "max_episodes -3 is out of range; use a whole number of at least 1."),
        ({"target_iterations": 0}, "target_iterations 0 is out of range; use 1 to 100."),
    ],
)
def test_bad_overrides_name_the_field(overrides: dict, sentence: str) -> None:
    with pytest.raises(SettingError) as info:
        StopConditions().overridden(overrides)
    assert str(info.value).startswith(sentence)
    assert info.value.field == next(iter(overrides))
