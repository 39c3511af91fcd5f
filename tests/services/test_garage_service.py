"""Building cars from ``drx garage add`` options."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from drx.config import project_root
from drx.errors import AlreadyExistsError, DrxError, NotFoundError, SettingError
from drx.services import garage


def test_defaults_are_deepracers() -> None:
    car = garage.vehicle_from_options("c")
    assert car.n_actions == 10 and car.max_steering == 30 and car.max_speed == 1.0
    assert (car.sensor, car.lidar, car.network) == ("camera", False, "compact")


def test_grid_options() -> None:
    car = garage.vehicle_from_options("c", max_steering=20, steering_levels=7, max_speed=3, speed_levels=3)
    assert car.n_actions == 21 and car.max_speed == 3 and car.max_steering == 20


def test_continuous_ranges() -> None:
    car = garage.vehicle_from_options("c", continuous=True, max_steering=25, min_speed=1, max_speed=3.5)
    assert car.continuous and car.steering_range == (-25, 25) and car.speed_range == (1, 3.5)


def test_actions_file_json_and_csv(tmp_path: Path) -> None:
    j = tmp_path / "a.json"
    j.write_text(json.dumps([{"steering_angle": 10, "speed": 1}, {"steering_angle": -10, "speed": 2}]))
    assert garage.vehicle_from_options("c", actions_file=j).n_actions == 2
    meta = tmp_path / "model_metadata.json"
    meta.write_text(json.dumps({"action_space": [{"steering_angle": 0, "speed": 1, "index": 0}] * 3}))
    assert garage.vehicle_from_options("c", actions_file=meta).n_actions == 3
    c = tmp_path / "a.csv"
    c.write_text("steering,speed\n30,1\n0,2\n-30,1\n")
    assert [a.speed for a in garage.vehicle_from_options("c", actions_file=c).actions] == [1, 2, 1]


@pytest.mark.parametrize(
    ("kwargs", "words"),
    [
        ({"max_steering": 31}, ("31", "1 to 30")),
        ({"steering_levels": 4}, ("4", "3, 5 or 7")),
        ({"max_speed": 0.05}, ("0.05", "0.1 to 4")),
        ({"speed_levels": 5}, ("5", "1, 2 or 3")),
        ({"sensor": "radar"}, ("radar",)),
        ({"network": "huge"}, ("huge",)),
        ({"continuous": True, "steering_levels": 5}, ("continuous cannot be combined with steering_levels",)),
        ({"continuous": True, "min_speed": 0.2}, ("0.2", "0.5")),
        ({"min_speed": 1.0}, ("min_speed applies only to continuous cars",)),
        ({"min_steering": -20.0, "min_speed": 1.0}, ("min_steering, min_speed apply only to continuous",)),
    ],
)
def test_bad_options(kwargs: dict, words: tuple) -> None:
    with pytest.raises(DrxError) as info:
        garage.vehicle_from_options("c", **kwargs)
    for word in words:
        assert word in str(info.value)


def test_actions_file_errors(tmp_path: Path) -> None:
    one = tmp_path / "one.json"
    one.write_text(json.dumps([{"steering_angle": 0, "speed": 1}]))
    with pytest.raises(DrxError, match="2 to 30"):
        garage.vehicle_from_options("c", actions_file=one)
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(DrxError, match="malformed"):
        garage.vehicle_from_options("c", actions_file=bad)
    with pytest.raises(NotFoundError):
        garage.vehicle_from_options("c", actions_file=tmp_path / "missing.csv")
    short = tmp_path / "short.csv"
    short.write_text("steering,speed\n10,1\n-10\n")
    with pytest.raises(DrxError, match="row 3 '-10' has one value, not steering and speed"):
        garage.vehicle_from_options("c", actions_file=short)


def test_from_toml_excludes_other_options() -> None:
    toml = project_root() / "garage" / "default.toml"
    assert garage.vehicle_from_options("c", from_file=toml).name == "c"
    with pytest.raises(SettingError, match="^from_file cannot be combined with max_speed; edit the TOML"):
        garage.vehicle_from_options("c", from_file=toml, max_speed=2)


def test_store_list_remove() -> None:
    garage.add_vehicle(garage.vehicle_from_options("zed", max_speed=2))
    assert [e.name for e in garage.list_vehicles()] == ["default", "zed"]
    assert garage.get_vehicle("zed").max_speed == 2
    with pytest.raises(AlreadyExistsError):
        garage.add_vehicle(garage.vehicle_from_options("zed"))
    with pytest.raises(AlreadyExistsError):
        garage.add_vehicle(garage.vehicle_from_options("default"))
    garage.remove_vehicle("zed")
    with pytest.raises(NotFoundError, match="known cars: default"):
        garage.get_vehicle("zed")
    with pytest.raises(DrxError, match="built in"):
        garage.remove_vehicle("default")
