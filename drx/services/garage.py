"""The garage: cars (action space, sensors, network) stored in the registry.

The car ``default`` is built in (DeepRacer's default car) and always present;
it cannot be added or removed. Models keep a snapshot of their car, so
removing or re-adding a car never changes an existing model.
"""

from __future__ import annotations

import csv
import json
from collections.abc import Callable
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import Any

from drx.errors import AlreadyExistsError, DrxError, NotFoundError, SettingError, not_a_file
from drx.registry import quick
from drx.services.names import check_item_name
from drx.vehicle import (
    CUSTOM_ACTIONS_RANGE,
    DEFAULT_NETWORK,
    MAX_SPEED_RANGE,
    MAX_STEERING_RANGE,
    Action,
    Vehicle,
    default_vehicle,
    grid_actions,
)

BUILTIN_CAR = "default"
# An action space from a racing line: how many actions unless told (racers' lists hold 10-20), and the
# limits the line is solved for unless told: DeepRacer's whole range, 30 degrees and 4 m/s.
RACING_LINE_ACTIONS = 15
RACING_LINE_MAX_STEERING = 30.0  # [deg]
RACING_LINE_MAX_SPEED = 4.0  # [m/s]

# Derives a car's actions from a track's racing line: (count, max_steering [deg], max_speed [m/s]) ->
# actions. The CLI passes drx.evaluate.action_space's; the garage may not import drx.evaluate (layers).
LineActions = Callable[[int, float, float], tuple[Action, ...]]


@dataclass(frozen=True)
class GarageEntry:
    """A car as the garage lists it."""

    vehicle: Vehicle
    source: str  # "built-in", "options", or the file it was loaded from
    created_at: datetime | None

    @property
    def name(self) -> str:
        """The car's name."""
        return self.vehicle.name


ACTION_FILE_SUFFIXES = (".json", ".csv", ".txt", ".tsv", "")


def read_actions_file(path: Path) -> tuple[Action, ...]:
    """Read a custom action list: JSON (a list of ``{steering_angle, speed}`` or a whole
    ``model_metadata.json``) or CSV/text with two columns, steering [deg] and speed [m/s]."""
    if not path.is_file():
        raise not_a_file(path, "Action file", "give a .json, .csv or .txt file of actions")
    if path.suffix.lower() not in ACTION_FILE_SUFFIXES:
        raise DrxError(
            f"Action file {path.name} is not an action list; give a .json list of "
            "{steering_angle, speed} or a .csv/.txt file of rows 'steering,speed'."
        )
    text = path.read_text(encoding="utf-8", errors="replace")
    try:
        if path.suffix.lower() == ".json":
            data = json.loads(text)
            items = data.get("action_space") if isinstance(data, dict) else data
            if not isinstance(items, list):
                raise ValueError("expected a list of actions")
            return tuple(Action(float(a["steering_angle"]), float(a["speed"])) for a in items)
        actions = []
        lines = [line for line in text.splitlines() if line.strip() and not line.startswith("#")]
        for number, row in enumerate(csv.reader(lines), start=1):
            cells = [c.strip() for c in row if c.strip()]
            if len(cells) == 1:
                cells = cells[0].split()
            if len(cells) < 2:
                raise ValueError(f"row {number} {', '.join(cells)!r} has one value, not steering and speed")
            try:
                actions.append(Action(float(cells[0]), float(cells[1])))
            except ValueError:
                if actions:  # only the first row may be a header
                    raise
        if not actions:
            raise ValueError("no row holds two numbers")
        return tuple(actions)
    except (ValueError, KeyError, TypeError, IndexError) as exc:
        raise DrxError(
            f"Action file {path.name} is malformed ({exc}); give a JSON list of "
            "{steering_angle, speed} or CSV rows 'steering,speed'."
        ) from exc


def vehicle_from_options(
    name: str,
    *,
    from_file: Path | None = None,
    actions_file: Path | None = None,
    continuous: bool = False,
    max_steering: float | None = None,
    steering_levels: int | None = None,
    max_speed: float | None = None,
    speed_levels: int | None = None,
    min_steering: float | None = None,
    min_speed: float | None = None,
    sensor: str | None = None,
    lidar: bool = False,
    network: str | None = None,
    from_racing_line: LineActions | None = None,
    actions: int | None = None,
) -> Vehicle:
    """Build and validate a car from ``drx garage add`` options (nothing is stored).

    Exactly one way to give the action space: a TOML file (``from_file``), a
    custom action list (``actions_file``), ``continuous`` ranges, a track's
    racing line (``from_racing_line``, ``actions`` of them, within ``max_steering``
    and ``max_speed``), or DeepRacer's grid (``max_steering`` x ``steering_levels``,
    ``max_speed`` x ``speed_levels``, defaulting to DeepRacer's 30 deg x 5, 1 m/s x 2).

    :param name: the car's name.
    :param from_file: a car's TOML file.
    :param actions_file: a custom action list (JSON or CSV).
    :param continuous: a continuous action space.
    :param max_steering: [deg] the grid's, the ranges' or the racing line's steering lock.
    :param steering_levels: the grid's steering values.
    :param max_speed: [m/s] the grid's, the ranges' or the racing line's top speed.
    :param speed_levels: the grid's speed values.
    :param min_steering: [deg] a continuous car's lowest steering.
    :param min_speed: [m/s] a continuous car's lowest speed.
    :param sensor: ``camera`` or ``stereo``.
    :param lidar: add a lidar.
    :param network: the policy network.
    :param from_racing_line: derives the actions from a track's racing line (:data:`LineActions`); it is
        called only once every other option has been checked, as the solve takes seconds.
    :param actions: how many actions ``from_racing_line`` derives, 2 to 30 (default
        :data:`RACING_LINE_ACTIONS`).
    """
    check_item_name(name, "car")
    grid = {"steering_levels": steering_levels, "speed_levels": speed_levels}
    ranges = {"min_steering": min_steering, "min_speed": min_speed}
    limits = {"max_steering": max_steering, "max_speed": max_speed}
    if actions is not None and from_racing_line is None:
        raise SettingError("{field} applies only to {from_racing_line}.", "actions", "from_racing_line")
    if from_file is not None:
        extra = {**grid, **ranges, **limits, "sensor": sensor, "network": network}
        used = [k for k, v in extra.items() if v is not None] + (["lidar"] if lidar else [])
        used += ["actions_file"] if actions_file else []
        used += ["continuous"] if continuous else []
        used += ["from_racing_line"] if from_racing_line is not None else []
        if used:
            raise _not_with("from_file", used, "; edit the TOML file instead")
        if not from_file.is_file():
            raise not_a_file(from_file, "Car file", "give a TOML file such as garage/default.toml")
        from drx.garage_files import load_vehicle_toml

        return load_vehicle_toml(from_file, name)
    look: dict[str, Any] = {
        "sensor": sensor or "camera",
        "lidar": lidar,
        "network": network or DEFAULT_NETWORK,
    }
    if from_racing_line is not None:
        used = [k for k, v in {**grid, **ranges}.items() if v is not None]
        used += ["continuous"] if continuous else []
        used += ["actions_file"] if actions_file else []
        if used:  # the line sets the action list; only its count and the car's limits are the user's
            names = ", ".join("{" + other + "}" for other in used)
            raise SettingError(
                "{field} cannot be combined with "
                + names
                + "; it sets the actions ({actions} says how many).",
                "from_racing_line",
                *used,
                "actions",
            )
        count = RACING_LINE_ACTIONS if actions is None else actions
        lock = RACING_LINE_MAX_STEERING if max_steering is None else max_steering
        top = RACING_LINE_MAX_SPEED if max_speed is None else max_speed
        _check_racing_line_limits(count, lock, top)
        return Vehicle(name=name, actions=from_racing_line(count, lock, top), **look)
    if actions_file is not None:
        used = [k for k, v in {**grid, **ranges, **limits}.items() if v is not None]
        used += ["continuous"] if continuous else []
        if used:
            raise _not_with("actions_file", used)
        return Vehicle(name=name, actions=read_actions_file(actions_file), **look)
    if continuous:
        used = [k for k, v in grid.items() if v is not None]
        if used:
            raise _not_with("continuous", used, "; give ranges instead")
        hi_steer = 30.0 if max_steering is None else max_steering
        lo_steer = -hi_steer if min_steering is None else min_steering
        hi_speed = 1.0 if max_speed is None else max_speed
        lo_speed = 0.5 if min_speed is None else min_speed
        return Vehicle(
            name=name,
            continuous=True,
            steering_range=(lo_steer, hi_steer),
            speed_range=(lo_speed, hi_speed),
            **look,
        )
    used = [k for k, v in ranges.items() if v is not None]
    if used:
        names = ", ".join("{" + key + "}" for key in used)
        verb = "applies" if len(used) == 1 else "apply"
        raise SettingError(f"{names} {verb} only to {{continuous}} cars.", *used, "continuous")
    grid_list = grid_actions(
        30.0 if max_steering is None else max_steering,
        5 if steering_levels is None else steering_levels,
        1.0 if max_speed is None else max_speed,
        2 if speed_levels is None else speed_levels,
    )
    return Vehicle(name=name, actions=grid_list, **look)


def add_vehicle(vehicle: Vehicle, source: str = "options") -> GarageEntry:
    """Store ``vehicle`` in the garage under its name.

    :raises AlreadyExistsError: the name is taken (or is the built-in ``default``).
    """
    check_item_name(vehicle.name, "car")
    if vehicle.name == BUILTIN_CAR:
        raise AlreadyExistsError(f"Car {BUILTIN_CAR!r} is built in; choose another name.")
    from sqlalchemy import select

    from drx.registry import VehicleRow, session_scope

    with session_scope() as session:
        if session.scalar(select(VehicleRow.id).where(VehicleRow.name == vehicle.name)) is not None:
            raise AlreadyExistsError(
                f"Car {vehicle.name!r} already exists; choose another name or `drx garage rm` it first."
            )
        row = VehicleRow(name=vehicle.name, spec=vehicle.to_dict(), source=source)
        session.add(row)
        session.flush()
        return GarageEntry(vehicle, source, row.created_at)


def list_vehicles() -> list[GarageEntry]:
    """Every car: the built-in ``default`` first, then the stored ones by name (read at once from a
    current SQLite registry, :mod:`drx.registry.quick`)."""
    rows = quick.vehicles()
    if rows is not None:
        stored = [
            GarageEntry(Vehicle.from_dict({**r.spec, "name": r.name}), r.source or "options", r.created_at)
            for r in rows
        ]
    else:
        from sqlalchemy import select

        from drx.registry import VehicleRow, session_scope

        with session_scope() as session:
            found = session.scalars(select(VehicleRow).order_by(VehicleRow.name)).all()
            stored = [GarageEntry(r.vehicle(), r.source or "options", r.created_at) for r in found]
    return [GarageEntry(default_vehicle(BUILTIN_CAR), "built-in", None), *stored]


def get_entry(name: str) -> GarageEntry:
    """The garage entry named ``name``.

    :raises NotFoundError: no such car; the message lists the known ones.
    """
    if name == BUILTIN_CAR:
        return GarageEntry(default_vehicle(BUILTIN_CAR), "built-in", None)
    from sqlalchemy import select

    from drx.registry import VehicleRow, session_scope

    with session_scope() as session:
        row = session.scalar(select(VehicleRow).where(VehicleRow.name == name))
        if row is not None:
            return GarageEntry(row.vehicle(), row.source or "options", row.created_at)
    known = ", ".join(e.name for e in list_vehicles())
    raise NotFoundError(f"Car {name!r} is not in the garage; known cars: {known}.")


def get_vehicle(name: str) -> Vehicle:
    """The car named ``name`` (see :func:`get_entry`)."""
    return get_entry(name).vehicle


def remove_vehicle(name: str) -> None:
    """Remove a stored car. Models that use it keep their own snapshot.

    :raises DrxError: the car is the built-in ``default`` or does not exist.
    """
    if name == BUILTIN_CAR:
        raise DrxError(f"Car {BUILTIN_CAR!r} is built in and cannot be removed.")
    from sqlalchemy import select

    from drx.registry import VehicleRow, session_scope

    with session_scope() as session:
        row = session.scalar(select(VehicleRow).where(VehicleRow.name == name))
        if row is not None:
            session.delete(row)
            return
    get_entry(name)  # raises NotFoundError listing the known cars


def vehicle_metadata(vehicle: Vehicle, algorithm: str = "ppo") -> dict[str, Any]:
    """The car as DeepRacer's ``model_metadata.json`` dict (the ``--json`` of ``garage show``)."""
    return vehicle.to_model_metadata(algorithm)


def _check_racing_line_limits(count: int, max_steering: float, max_speed: float) -> None:
    """Check a racing-line car's action count and limits before its line is solved.

    :raises SettingError: a value out of DeepRacer's range (2-30 actions, 1-30 deg, 0.1-4 m/s).
    """
    lo, hi = CUSTOM_ACTIONS_RANGE
    if not lo <= count <= hi:
        raise SettingError(
            "{field} {value} is out of range; DeepRacer's custom action lists hold {lo} to {hi} actions.",
            "actions",
            value=count,
            lo=lo,
            hi=hi,
        )
    for field, value, (low, high), unit in (
        ("max_steering", max_steering, MAX_STEERING_RANGE, "degrees"),
        ("max_speed", max_speed, MAX_SPEED_RANGE, "m/s"),
    ):
        if not low <= value <= high:
            raise SettingError(
                "{field} {value:g} is out of range; use {lo:g} to {hi:g} " + unit + ".",
                field,
                value=value,
                lo=low,
                hi=high,
            )


def _not_with(field: str, others: list[str], fix: str = "") -> SettingError:
    """``field`` given together with ``others``, which it excludes."""
    names = ", ".join("{" + other + "}" for other in others)
    return SettingError("{field} cannot be combined with " + names + fix + ".", field, *others)
