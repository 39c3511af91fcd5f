"""A DeepRacer car: its action space, sensors and network.

This is the one description of a car that the garage, the registry, the
simulator and the trainer share. Ranges and defaults are DeepRacer's
(``../shared/DEEPRACER.md`` section 1). Every constructor validates, raising
:class:`~drx.errors.DrxError` with a sentence that names the value and the range.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

from drx.errors import DrxError, SettingError

# DeepRacer's limits for discrete action spaces built from a grid.
MAX_STEERING_RANGE = (1.0, 30.0)  # [deg]
STEERING_LEVELS = (3, 5, 7)
MAX_SPEED_RANGE = (0.1, 4.0)  # [m/s]
SPEED_LEVELS = (1, 2, 3)
# Custom action lists.
CUSTOM_ACTIONS_RANGE = (2, 30)
STEERING_LIMIT = 30.0  # [deg] any action's |steering|
SPEED_LIMIT = (0.1, 4.0)  # [m/s] any discrete action's speed
CONTINUOUS_SPEED_LIMIT = (0.5, 4.0)  # [m/s]

SENSOR_CAMERAS = ("camera", "stereo")
NETWORKS = ("shallow", "deep", "compact")
# drx's cars default to the CPU network: on a 2-core laptop it trains ~10x faster than DeepRacer's
# `shallow` and laps reinvent_base in minutes (docs/TRAINING.md, benchmarks/time_to_lap.py
# --defaults); `--network shallow` gives DeepRacer's. Both export to the car (drx.interchange.car.car_graph).
DEFAULT_NETWORK = "compact"
DEEPRACER_NETWORK = "shallow"  # what a DeepRacer model_metadata.json without neural_network means

# model_metadata.json names.
METADATA_SENSOR = {"camera": "FRONT_FACING_CAMERA", "stereo": "STEREO_CAMERAS"}
METADATA_NETWORK = {
    "shallow": "DEEP_CONVOLUTIONAL_NETWORK_SHALLOW",
    "deep": "DEEP_CONVOLUTIONAL_NETWORK",
    "compact": "DRX_COMPACT_NETWORK",
}


@dataclass(frozen=True)
class Action:
    """One discrete action: commanded steering [deg, + = left] and speed [m/s]."""

    steering_angle: float
    speed: float


@dataclass(frozen=True)
class Vehicle:
    """A car in the garage.

    :param name: the car's name in the garage.
    :param actions: the discrete actions, in action-index order; empty when continuous.
    :param continuous: whether the action space is continuous.
    :param steering_range: (low, high) [deg] of a continuous car.
    :param speed_range: (low, high) [m/s] of a continuous car.
    :param sensor: ``camera`` (front camera) or ``stereo`` (two front cameras).
    :param lidar: whether the car carries a lidar.
    :param network: the policy network: ``shallow``, ``deep`` or ``compact``.
    """

    name: str = "default"
    actions: tuple[Action, ...] = field(default_factory=tuple)
    continuous: bool = False
    steering_range: tuple[float, float] = (-30.0, 30.0)
    speed_range: tuple[float, float] = (0.5, 1.0)
    sensor: str = "camera"
    lidar: bool = False
    network: str = DEFAULT_NETWORK

    def __post_init__(self) -> None:
        _check_sensors(self.sensor, self.network)
        if self.continuous:
            _check_continuous(self.steering_range, self.speed_range)
        else:
            _check_actions(self.actions)

    # ----- derived facts -------------------------------------------------
    @property
    def n_actions(self) -> int:
        """Number of discrete actions (0 for a continuous car)."""
        return 0 if self.continuous else len(self.actions)

    @property
    def max_speed(self) -> float:
        """The fastest speed the car can command [m/s]."""
        if self.continuous:
            return float(self.speed_range[1])
        return max(a.speed for a in self.actions)

    @property
    def max_steering(self) -> float:
        """The largest |steering| the car can command [deg]."""
        if self.continuous:
            return float(max(abs(self.steering_range[0]), abs(self.steering_range[1])))
        return max(abs(a.steering_angle) for a in self.actions)

    def summary(self) -> str:
        """A one-line description of the action space, e.g. ``10 actions, 30° x 5, 1 m/s x 2``."""
        if self.continuous:
            s, v = self.steering_range, self.speed_range
            return f"continuous, steering {s[0]:g}..{s[1]:g}°, speed {v[0]:g}..{v[1]:g} m/s"
        steers = sorted({a.steering_angle for a in self.actions})
        speeds = sorted({a.speed for a in self.actions})
        if len(steers) * len(speeds) == len(self.actions):
            return (
                f"{len(self.actions)} actions, {self.max_steering:g}° x {len(steers)}, "
                f"{self.max_speed:g} m/s x {len(speeds)}"
            )
        return f"{len(self.actions)} custom actions, up to {self.max_steering:g}°, {self.max_speed:g} m/s"

    def scale_continuous(self, action: Any) -> tuple[float, float]:
        """Map a policy output in [-1, 1]^2 (steering, speed) to (deg, m/s)."""
        a = [min(1.0, max(-1.0, float(v))) for v in action]
        lo, hi = self.steering_range
        steer = lo + (a[0] + 1.0) * 0.5 * (hi - lo)
        lo, hi = self.speed_range
        speed = lo + (a[1] + 1.0) * 0.5 * (hi - lo)
        return steer, speed

    # ----- conversions ---------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """A JSON-friendly dict (drx's own storage format)."""
        d = asdict(self)
        d["actions"] = [asdict(a) for a in self.actions]
        d["steering_range"] = list(self.steering_range)
        d["speed_range"] = list(self.speed_range)
        return d

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Vehicle:
        """Inverse of :meth:`to_dict`."""
        d = dict(d)
        d["actions"] = tuple(
            Action(float(a["steering_angle"]), float(a["speed"])) for a in d.get("actions", ())
        )
        for key in ("steering_range", "speed_range"):
            if key in d:
                d[key] = tuple(float(v) for v in d[key])
        return cls(**d)

    def to_model_metadata(self, algorithm: str = "ppo", simulator: str = "5") -> dict[str, Any]:
        """The car as DeepRacer's ``model_metadata.json``; ``simulator`` is the ``version`` it names:
        the DeepRacer simulator whose car the model trained on (``drx.settings.car``)."""
        if self.continuous:
            action_space: Any = {
                "steering_angle": {"low": self.steering_range[0], "high": self.steering_range[1]},
                "speed": {"low": self.speed_range[0], "high": self.speed_range[1]},
            }
        else:
            action_space = [
                {"steering_angle": a.steering_angle, "speed": a.speed, "index": i}
                for i, a in enumerate(self.actions)
            ]
        sensors = [METADATA_SENSOR[self.sensor]] + (["LIDAR"] if self.lidar else [])
        return {
            "action_space": action_space,
            "action_space_type": "continuous" if self.continuous else "discrete",
            "sensor": sensors,
            "neural_network": METADATA_NETWORK[self.network],
            "training_algorithm": "sac" if algorithm == "sac" else "clipped_ppo",
            "version": str(simulator),
        }

    @classmethod
    def from_model_metadata(cls, name: str, meta: dict[str, Any]) -> Vehicle:
        """Build a car from DeepRacer's ``model_metadata.json`` content."""
        sensors = [str(s).upper() for s in meta.get("sensor", ["FRONT_FACING_CAMERA"])]
        known = {"FRONT_FACING_CAMERA", "STEREO_CAMERAS", "LIDAR", "SECTOR_LIDAR"}
        for s in sensors:
            if s not in known:
                raise DrxError(f"Unknown sensor {s!r} in model_metadata.json; use one of {sorted(known)}.")
        sensor = "stereo" if "STEREO_CAMERAS" in sensors else "camera"
        lidar = "LIDAR" in sensors or "SECTOR_LIDAR" in sensors
        reverse_net = {v: k for k, v in METADATA_NETWORK.items()}
        net_name = meta.get("neural_network", METADATA_NETWORK[DEEPRACER_NETWORK])
        if net_name not in reverse_net:
            raise DrxError(f"Unknown neural_network {net_name!r}; use one of {sorted(reverse_net)}.")
        space = meta.get("action_space")
        kind = meta.get("action_space_type", "continuous" if isinstance(space, dict) else "discrete")
        if kind == "continuous":
            if not isinstance(space, dict):
                raise DrxError(
                    "A continuous model_metadata.json needs action_space as {steering_angle, speed}."
                )
            return cls(
                name=name,
                continuous=True,
                steering_range=(
                    float(space["steering_angle"]["low"]),
                    float(space["steering_angle"]["high"]),
                ),
                speed_range=(float(space["speed"]["low"]), float(space["speed"]["high"])),
                sensor=sensor,
                lidar=lidar,
                network=reverse_net[net_name],
            )
        if not isinstance(space, list):
            raise DrxError("A discrete model_metadata.json needs action_space as a list of actions.")
        actions = tuple(Action(float(a["steering_angle"]), float(a["speed"])) for a in space)
        return cls(name=name, actions=actions, sensor=sensor, lidar=lidar, network=reverse_net[net_name])


def grid_actions(
    max_steering: float = 30.0, steering_levels: int = 5, max_speed: float = 1.0, speed_levels: int = 2
) -> tuple[Action, ...]:
    """DeepRacer's discrete action grid: steering spread symmetrically, speeds max*k/n.

    Actions are ordered as the console orders them: by steering from the
    leftmost (positive) down to the rightmost, then by speed ascending.
    """
    lo_s, hi_s = MAX_STEERING_RANGE
    if not lo_s <= max_steering <= hi_s:
        raise SettingError(
            "{field} {value:g} is out of range; use {lo:g} to {hi:g} degrees.",
            "max_steering",
            value=max_steering,
            lo=lo_s,
            hi=hi_s,
        )
    if steering_levels not in STEERING_LEVELS:
        raise SettingError(
            "{field} {value} is not allowed; use one of 3, 5 or 7.", "steering_levels", value=steering_levels
        )
    lo_v, hi_v = MAX_SPEED_RANGE
    if not lo_v <= max_speed <= hi_v:
        raise SettingError(
            "{field} {value:g} is out of range; use {lo:g} to {hi:g} m/s.",
            "max_speed",
            value=max_speed,
            lo=lo_v,
            hi=hi_v,
        )
    if speed_levels not in SPEED_LEVELS:
        raise SettingError(
            "{field} {value} is not allowed; use one of 1, 2 or 3.", "speed_levels", value=speed_levels
        )
    half = (steering_levels - 1) // 2
    steers = [round(max_steering * k / half, 4) for k in range(half, -half - 1, -1)]
    speeds = [round(max_speed * k / speed_levels, 4) for k in range(1, speed_levels + 1)]
    return tuple(Action(s, v) for s in steers for v in speeds)


def default_vehicle(name: str = "default") -> Vehicle:
    """DeepRacer's default car, 10 actions (30° x 5, 1 m/s x 2) and a front camera, with drx's
    default network (:data:`DEFAULT_NETWORK`)."""
    return Vehicle(name=name, actions=grid_actions())


def _check_actions(actions: tuple[Action, ...]) -> None:
    lo, hi = CUSTOM_ACTIONS_RANGE
    if not lo <= len(actions) <= hi:
        raise DrxError(f"The action space has {len(actions)} actions; a car needs {lo} to {hi}.")
    for i, a in enumerate(actions):
        if not (math.isfinite(a.steering_angle) and abs(a.steering_angle) <= STEERING_LIMIT):
            limit = f"{STEERING_LIMIT:g}"
            raise DrxError(f"Action {i} steers {a.steering_angle:g} degrees; use -{limit} to {limit}.")
        if not (math.isfinite(a.speed) and SPEED_LIMIT[0] <= a.speed <= SPEED_LIMIT[1]):
            raise DrxError(
                f"Action {i} has speed {a.speed:g} m/s; use {SPEED_LIMIT[0]:g} to {SPEED_LIMIT[1]:g}."
            )


def _check_continuous(steering: tuple[float, float], speed: tuple[float, float]) -> None:
    lo, hi = steering
    if not (-STEERING_LIMIT <= lo < hi <= STEERING_LIMIT):
        raise DrxError(
            f"Steering range {lo:g}..{hi:g} is invalid; use low < high within "
            f"-{STEERING_LIMIT:g}..{STEERING_LIMIT:g} degrees."
        )
    lo, hi = speed
    a, b = CONTINUOUS_SPEED_LIMIT
    if not (a <= lo < hi <= b):
        raise DrxError(f"Speed range {lo:g}..{hi:g} is invalid; use low < high within {a:g}..{b:g} m/s.")


def _check_sensors(sensor: str, network: str) -> None:
    if sensor not in SENSOR_CAMERAS:
        raise SettingError(
            "{field} {value!r} is unknown; use one of {allowed} (plus {lidar}).",
            "sensor",
            "lidar",
            value=sensor,
            allowed=", ".join(SENSOR_CAMERAS),
        )
    if network not in NETWORKS:
        raise SettingError(
            "{field} {value!r} is unknown; use one of {allowed}.",
            "network",
            value=network,
            allowed=", ".join(NETWORKS),
        )
