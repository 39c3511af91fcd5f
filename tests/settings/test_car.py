"""The car a model trains on, from the versions DeepRacer's own files write: the console's and
deepracer-for-cloud 5.x's ``"version": "5"`` (a string, as in ../shared/deepracer-models), DeepRacer
on AWS's JSON number ``6``, and the older or unreadable ones that get version 5's car with a note."""

from __future__ import annotations

import pytest

from drx.errors import SettingError
from drx.settings.car import CarSettings, check_simulator, simulator_of_metadata


@pytest.mark.parametrize(
    ("version", "car", "noted"),
    [(6, "6", False), ("6", "6", False), ("6.0", "6", False), ("v6", "6", False), (5, "5", False),
     ("5.0", "5", False), ("3", "5", True), (4.0, "5", True), ("seven", "5", True), (None, "5", False),
     ("", "5", False)],
)  # fmt: skip
def test_a_folders_version_names_its_car(version: object, car: str, noted: bool) -> None:
    got, note = simulator_of_metadata(version)
    assert got == car and (note is not None) == noted
    if note:
        assert f"names simulator version {version}" in note and "drives version 5's" in note


def test_only_the_cars_drx_has_are_settings() -> None:
    assert [check_simulator(v) for v in ("5", 6, "6.0")] == ["5", "6", "6"]
    for bad in ("4", "7", "", "six"):
        with pytest.raises(SettingError, match="is not a DeepRacer simulator drx has a car for; use 5"):
            check_simulator(bad)
    assert CarSettings() == CarSettings("6", False)  # new models: the venues' car
    with pytest.raises(SettingError):
        CarSettings("7")
