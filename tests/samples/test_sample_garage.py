"""The sample cars in garage/*.toml and drx.garage_files: load, round-trip, and clear errors."""

from __future__ import annotations

import tomllib
from dataclasses import replace
from pathlib import Path

import pytest

from drx.errors import DrxError, NotFoundError
from drx.garage_files import load_vehicle_toml, vehicle_from_toml_dict, vehicle_to_toml
from drx.vehicle import DEFAULT_NETWORK, Action, Vehicle, default_vehicle, grid_actions

from ._paths import GARAGE_FILES

IDS = [p.stem for p in GARAGE_FILES]


def test_every_sample_is_there() -> None:
    assert set(IDS) == {"default", "fast-discrete", "continuous", "stereo-lidar", "custom-actions"}


@pytest.mark.parametrize("path", GARAGE_FILES, ids=IDS)
def test_loads_into_a_valid_vehicle(path: Path) -> None:
    car = load_vehicle_toml(path, path.stem)
    assert isinstance(car, Vehicle)
    assert car.name == path.stem
    assert Vehicle.from_dict(car.to_dict()) == car
    meta = car.to_model_metadata("sac" if car.continuous else "ppo")
    assert Vehicle.from_model_metadata(path.stem, meta) == car
    assert isinstance(tomllib.loads(path.read_text(encoding="utf-8"))["description"], str)


@pytest.mark.parametrize("path", GARAGE_FILES, ids=IDS)
def test_round_trips_through_vehicle_to_toml(path: Path, tmp_path: Path) -> None:
    car = load_vehicle_toml(path, "car")
    text = vehicle_to_toml(car)
    out = tmp_path / "car.toml"
    out.write_text(text, encoding="utf-8")
    assert load_vehicle_toml(out, "car") == car
    assert vehicle_to_toml(load_vehicle_toml(out, "car")) == text


def test_default_is_deepracers_default() -> None:
    car = load_vehicle_toml(GARAGE_FILES[IDS.index("default")], "default")
    # The sample is DeepRacer's car with DeepRacer's network; drx's built-in one has drx's default network.
    assert replace(car, network=DEFAULT_NETWORK) == default_vehicle("default")
    assert car.n_actions == 10 and car.sensor == "camera" and not car.lidar and car.network == "shallow"


def test_the_other_samples() -> None:
    fast = load_vehicle_toml(GARAGE_FILES[IDS.index("fast-discrete")], "f")
    assert fast.actions == grid_actions(20.0, 5, 3.0, 3) and fast.n_actions == 15
    cont = load_vehicle_toml(GARAGE_FILES[IDS.index("continuous")], "c")
    assert cont.continuous and cont.steering_range == (-30.0, 30.0) and cont.speed_range == (0.5, 3.0)
    stereo = load_vehicle_toml(GARAGE_FILES[IDS.index("stereo-lidar")], "s")
    assert stereo.sensor == "stereo" and stereo.lidar
    assert stereo.to_model_metadata()["sensor"] == ["STEREO_CAMERAS", "LIDAR"]
    custom = load_vehicle_toml(GARAGE_FILES[IDS.index("custom-actions")], "x")
    assert 2 <= custom.n_actions <= 30
    assert custom.actions[0] == Action(30.0, 1.0)
    assert "custom" in custom.summary()


def test_custom_list_and_defaults_round_trip(tmp_path: Path) -> None:
    car = Vehicle(
        name="odd", actions=(Action(12.5, 0.7), Action(-3.0, 3.9)), sensor="stereo", network="compact"
    )
    assert vehicle_from_toml_dict(tomllib.loads(vehicle_to_toml(car)), "odd") == car
    minimal = {"action_space": {"type": "discrete", "actions": [{"steering_angle": 0, "speed": 1}] * 2}}
    loaded = vehicle_from_toml_dict(minimal, "m")
    assert loaded.sensor == "camera" and not loaded.lidar and loaded.network == DEFAULT_NETWORK == "compact"


GRID = (
    '[action_space]\ntype = "discrete"\n'
    "max_steering = 30\nsteering_levels = 5\nmax_speed = 1\nspeed_levels = 2\n"
)
CONT = '[action_space]\ntype = "continuous"\nsteering_low = -30\nsteering_high = 30\n'

MALFORMED = {
    "syntax": ("sensor = camera\n" + GRID, "not valid TOML"),
    "unknown_top_key": ("sensors = 'camera'\n" + GRID, "unknown key 'sensors'"),
    "unknown_sensor": ("sensor = 'lidar'\n" + GRID, "sensor = 'lidar' is unknown"),
    "lidar_not_bool": ("lidar = 'yes'\n" + GRID, "lidar = 'yes' must be true or false"),
    "unknown_network": ("network = 'resnet'\n" + GRID, "network = 'resnet' is unknown"),
    "description_not_str": ("description = 3\n" + GRID, "description must be a string"),
    "no_action_space": ("sensor = 'camera'\n", "needs an [action_space] table"),
    "action_space_not_table": ("action_space = 3\n", "needs an [action_space] table"),
    "unknown_type": ("[action_space]\ntype = 'grid'\n", "type = 'grid' is unknown"),
    "missing_type": ("[action_space]\nmax_steering = 30\n", "[action_space] needs type"),
    "steering_too_big": (
        GRID.replace("max_steering = 30", "max_steering = 45"),
        "max_steering = 45 is out of range",
    ),
    "steering_levels": (GRID.replace("steering_levels = 5", "steering_levels = 4"), "steering_levels = 4"),
    "levels_float": (GRID.replace("steering_levels = 5", "steering_levels = 5.0"), "steering_levels = 5.0"),
    "speed_too_big": (GRID.replace("max_speed = 1", "max_speed = 5"), "max_speed = 5 is out of range"),
    "speed_levels": (GRID.replace("speed_levels = 2", "speed_levels = 4"), "speed_levels = 4"),
    "speed_not_number": (GRID.replace("max_speed = 1", "max_speed = 'fast'"), "must be a finite number"),
    "speed_nan": (GRID.replace("max_speed = 1", "max_speed = nan"), "must be a finite number"),
    "missing_grid_key": (GRID.replace("speed_levels = 2\n", ""), "needs speed_levels"),
    "grid_and_actions": (
        GRID + "[[action_space.actions]]\nsteering_angle = 0\nspeed = 1\n",
        "both an actions list and grid keys",
    ),
    "one_action": (
        "[action_space]\ntype='discrete'\n[[action_space.actions]]\nsteering_angle=0\nspeed=1\n",
        "2 to 30",
    ),
    "action_steers_too_far": (
        "[action_space]\ntype='discrete'\n"
        "[[action_space.actions]]\nsteering_angle=40\nspeed=1\n"
        "[[action_space.actions]]\nsteering_angle=0\nspeed=1\n",
        "action 0 steers 40 degrees",
    ),
    "action_missing_speed": (
        "[action_space]\ntype='discrete'\n[[action_space.actions]]\nsteering_angle=0\n"
        "[[action_space.actions]]\nsteering_angle=0\nspeed=1\n",
        "action 0 needs speed",
    ),
    "actions_not_tables": ("[action_space]\ntype='discrete'\nactions = [1, 2]\n", "actions must be"),
    "continuous_missing": (CONT, "needs speed_low"),
    "continuous_low_above_high": (
        "[action_space]\ntype = 'continuous'\nsteering_low = 10\nsteering_high = 5\n"
        "speed_low = 0.5\nspeed_high = 3\n",
        "steering range 10..5 is invalid",
    ),
    "continuous_slow": (CONT + "speed_low = 0.1\nspeed_high = 3\n", "speed range 0.1..3 is invalid"),
    "continuous_grid_key": (
        CONT + "speed_low = 0.5\nspeed_high = 3\nmax_speed = 3\n",
        "unknown key 'max_speed'",
    ),
}


@pytest.mark.parametrize("case", sorted(MALFORMED))
def test_malformed_file_raises_one_clear_sentence(case: str, tmp_path: Path) -> None:
    text, expected = MALFORMED[case]
    path = tmp_path / f"{case}.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(DrxError) as info:
        load_vehicle_toml(path, "bad")
    message = str(info.value)
    assert expected in message
    assert str(path) in message, "the message names the file"
    assert "\n" not in message and message.endswith(".")
    assert message.count(". ") == 0, "one sentence"


def test_missing_and_binary_files(tmp_path: Path) -> None:
    with pytest.raises(NotFoundError, match="does not exist"):
        load_vehicle_toml(tmp_path / "nope.toml", "x")
    binary = tmp_path / "bin.toml"
    binary.write_bytes(b"\xff\xfe\x00junk")
    with pytest.raises(DrxError, match="not a text file"):
        load_vehicle_toml(binary, "x")
