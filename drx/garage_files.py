"""Vehicles as TOML files: the format of ``garage/*.toml``.

``drx garage add NAME --from garage/FILE.toml`` reads one with
:func:`load_vehicle_toml`; :func:`vehicle_to_toml` writes a car back out. The
schema (every key but ``action_space`` is optional; defaults are DeepRacer's)::

    description = "what this car is for"      # free text
    sensor = "camera"                          # "camera" | "stereo"
    lidar = false                              # true adds a lidar
    network = "shallow"                        # "shallow" | "deep" | "compact"

    [action_space]                             # one of three forms:
    type = "discrete"                          # 1. DeepRacer's grid
    max_steering = 30.0                        #    1..30 deg
    steering_levels = 5                        #    3, 5 or 7
    max_speed = 1.0                            #    0.1..4 m/s
    speed_levels = 2                           #    1, 2 or 3

    [action_space]                             # 2. an explicit list (2..30 actions)
    type = "discrete"
    [[action_space.actions]]
    steering_angle = 30.0                      #    -30..30 deg, + = left
    speed = 1.0                                #    0.1..4 m/s

    [action_space]                             # 3. continuous
    type = "continuous"
    steering_low = -30.0                       #    -30 <= low < high <= 30 deg
    steering_high = 30.0
    speed_low = 0.5                            #    0.5 <= low < high <= 4 m/s
    speed_high = 3.0

Malformed files raise :class:`~drx.errors.DrxError` with one sentence naming
the file, the key and the fix.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path
from typing import Any

import tomli_w

from drx.errors import DrxError, not_a_file
from drx.vehicle import (
    DEFAULT_NETWORK,
    MAX_SPEED_RANGE,
    MAX_STEERING_RANGE,
    NETWORKS,
    SENSOR_CAMERAS,
    SPEED_LEVELS,
    STEERING_LEVELS,
    Action,
    Vehicle,
    grid_actions,
)

TOP_KEYS = ("description", "sensor", "lidar", "network", "action_space")
GRID_KEYS = ("max_steering", "steering_levels", "max_speed", "speed_levels")
CONTINUOUS_KEYS = ("steering_low", "steering_high", "speed_low", "speed_high")
ACTION_KEYS = ("steering_angle", "speed")


def load_vehicle_toml(path: str | Path, name: str) -> Vehicle:
    """Read a vehicle TOML file and return the car, named ``name``.

    :raises NotFoundError: the file does not exist.
    :raises DrxError: the file is not valid TOML or does not follow the schema.
    """
    p = Path(path)
    if not p.is_file():
        raise not_a_file(p, "Vehicle file", "give the path of a TOML file such as garage/default.toml")
    try:
        data = tomllib.loads(p.read_text(encoding="utf-8"))
    except UnicodeDecodeError as err:
        raise DrxError(f"{p} is not a text file (TOML is UTF-8 text); give a TOML vehicle file.") from err
    except tomllib.TOMLDecodeError as err:
        raise DrxError(f"{p} is not valid TOML ({err}); fix the syntax at that line.") from err
    return vehicle_from_toml_dict(data, name, source=str(p))


def vehicle_from_toml_dict(data: dict[str, Any], name: str, source: str = "The vehicle file") -> Vehicle:
    """Build a car from a parsed vehicle TOML document (see the module docstring)."""
    _check_keys(data, TOP_KEYS, source, "at the top level")
    description = data.get("description", "")
    if not isinstance(description, str):
        raise DrxError(f"{source}: description must be a string in quotes.")
    sensor = data.get("sensor", "camera")
    if sensor not in SENSOR_CAMERAS:
        raise DrxError(f"{source}: sensor = {sensor!r} is unknown; use one of {_quoted(SENSOR_CAMERAS)}.")
    lidar = data.get("lidar", False)
    if not isinstance(lidar, bool):
        raise DrxError(f"{source}: lidar = {lidar!r} must be true or false.")
    network = data.get("network", DEFAULT_NETWORK)
    if network not in NETWORKS:
        raise DrxError(f"{source}: network = {network!r} is unknown; use one of {_quoted(NETWORKS)}.")

    space = data.get("action_space")
    if not isinstance(space, dict):
        raise DrxError(f'{source} needs an [action_space] table with type = "discrete" or "continuous".')
    kind = space.get("type")
    common = {"name": name, "sensor": sensor, "lidar": lidar, "network": network}
    if kind == "continuous":
        _check_keys(space, ("type", *CONTINUOUS_KEYS), source, "in [action_space]")
        lo_s, hi_s, lo_v, hi_v = (_number(space, key, source) for key in CONTINUOUS_KEYS)
        ranges = {"steering_range": (lo_s, hi_s), "speed_range": (lo_v, hi_v)}
        return _vehicle(source, continuous=True, **ranges, **common)
    if kind is None:
        raise DrxError(f'{source}: [action_space] needs type = "discrete" or "continuous".')
    if kind != "discrete":
        raise DrxError(
            f'{source}: [action_space] type = {kind!r} is unknown; use "discrete" or "continuous".'
        )
    if "actions" in space:
        if any(key in space for key in GRID_KEYS):
            raise DrxError(
                f"{source}: [action_space] has both an actions list and grid keys ({', '.join(GRID_KEYS)}); "
                "keep one of them."
            )
        _check_keys(space, ("type", "actions"), source, "in [action_space]")
        return _vehicle(source, actions=_action_list(space["actions"], source), **common)
    _check_keys(space, ("type", *GRID_KEYS), source, "in [action_space]")
    return _vehicle(source, actions=_grid(space, source), **common)


def vehicle_toml_dict(vehicle: Vehicle, description: str | None = None) -> dict[str, Any]:
    """The car as a vehicle TOML document (a dict); a grid action list is written as its four numbers."""
    space: dict[str, Any]
    if vehicle.continuous:
        space = {
            "type": "continuous",
            "steering_low": float(vehicle.steering_range[0]),
            "steering_high": float(vehicle.steering_range[1]),
            "speed_low": float(vehicle.speed_range[0]),
            "speed_high": float(vehicle.speed_range[1]),
        }
    else:
        grid = _as_grid(vehicle.actions)
        if grid is not None:
            space = {"type": "discrete", **grid}
        else:
            acts = vehicle.actions
            space = {
                "type": "discrete",
                "actions": [{"steering_angle": a.steering_angle, "speed": a.speed} for a in acts],
            }
    return {
        "description": description if description is not None else f"{vehicle.name}: {vehicle.summary()}",
        "sensor": vehicle.sensor,
        "lidar": vehicle.lidar,
        "network": vehicle.network,
        "action_space": space,
    }


def vehicle_to_toml(vehicle: Vehicle, description: str | None = None) -> str:
    """The car as vehicle TOML text, which :func:`load_vehicle_toml` reads back to an equal car."""
    return tomli_w.dumps(vehicle_toml_dict(vehicle, description))


# ----- helpers ----------------------------------------------------------------
def _vehicle(source: str, **kwargs: Any) -> Vehicle:
    """Construct the car, naming the file in any validation error."""
    try:
        return Vehicle(**kwargs)
    except DrxError as err:
        msg = str(err)
        raise DrxError(f"{source}: {msg[:1].lower()}{msg[1:]}") from err


def _check_keys(table: dict[str, Any], allowed: tuple[str, ...], source: str, where: str) -> None:
    unknown = [k for k in table if k not in allowed]
    if unknown:
        key = unknown[0]
        raise DrxError(f"{source}: unknown key {key!r} {where}; use {_quoted(allowed)}.")


def _number(table: dict[str, Any], key: str, source: str, where: str = "[action_space]") -> float:
    """A required finite number (int or float, not a bool)."""
    if key not in table:
        raise DrxError(f"{source}: {where} needs {key} = <number>.")
    value = table[key]
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise DrxError(f"{source}: {key} = {value!r} in {where} must be a finite number.")
    return float(value)


def _integer(table: dict[str, Any], key: str, allowed: tuple[int, ...], source: str) -> int:
    if key not in table:
        raise DrxError(f"{source}: [action_space] needs {key} = one of {_quoted(allowed)}.")
    value = table[key]
    if isinstance(value, bool) or not isinstance(value, int) or value not in allowed:
        raise DrxError(f"{source}: {key} = {value!r} is not allowed; use one of {_quoted(allowed)}.")
    return value


def _grid(space: dict[str, Any], source: str) -> tuple[Action, ...]:
    """DeepRacer's action grid from max_steering, steering_levels, max_speed and speed_levels."""
    max_steering = _number(space, "max_steering", source)
    lo, hi = MAX_STEERING_RANGE
    if not lo <= max_steering <= hi:
        msg = f"max_steering = {max_steering:g} is out of range; use {lo:g} to {hi:g} degrees."
        raise DrxError(f"{source}: {msg}")
    steering_levels = _integer(space, "steering_levels", STEERING_LEVELS, source)
    max_speed = _number(space, "max_speed", source)
    lo, hi = MAX_SPEED_RANGE
    if not lo <= max_speed <= hi:
        raise DrxError(f"{source}: max_speed = {max_speed:g} is out of range; use {lo:g} to {hi:g} m/s.")
    speed_levels = _integer(space, "speed_levels", SPEED_LEVELS, source)
    return grid_actions(max_steering, steering_levels, max_speed, speed_levels)


def _action_list(actions: Any, source: str) -> tuple[Action, ...]:
    """An explicit action list from [[action_space.actions]] tables."""
    if not isinstance(actions, list) or not all(isinstance(a, dict) for a in actions):
        raise DrxError(
            f"{source}: actions must be [[action_space.actions]] tables, each with steering_angle and speed."
        )
    out = []
    for i, a in enumerate(actions):
        where = f"action {i}"
        _check_keys(a, ACTION_KEYS, source, f"in {where}")
        out.append(Action(_number(a, "steering_angle", source, where), _number(a, "speed", source, where)))
    return tuple(out)


def _as_grid(actions: tuple[Action, ...]) -> dict[str, Any] | None:
    """The grid parameters that produce exactly ``actions``, or None for a custom list."""
    if not actions:
        return None
    max_steering = max(abs(a.steering_angle) for a in actions)
    max_speed = max(a.speed for a in actions)
    for steering_levels in STEERING_LEVELS:
        for speed_levels in SPEED_LEVELS:
            if steering_levels * speed_levels != len(actions):
                continue
            try:
                grid = grid_actions(max_steering, steering_levels, max_speed, speed_levels)
            except DrxError:
                continue
            if grid == actions:
                return {
                    "max_steering": float(max_steering),
                    "steering_levels": steering_levels,
                    "max_speed": float(max_speed),
                    "speed_levels": speed_levels,
                }
    return None


def _quoted(values: tuple[Any, ...]) -> str:
    items = [f'"{v}"' if isinstance(v, str) else str(v) for v in values]
    return ", ".join(items[:-1]) + " or " + items[-1] if len(items) > 1 else items[0]
