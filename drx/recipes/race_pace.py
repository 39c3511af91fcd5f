"""The race-pace recipe: everything a fast model needs for one track and direction, from drx's racing line.

``drx model create NAME --track T --recipe race-pace`` (issue 41) builds, for the track as driven:

- **the car**: DeepRacer's fastest (30 degrees of lock, 4 m/s), its action space taken from the
  racing line: :data:`DISCRETE` (``race-pace-discrete``), 15 actions clustered from the line's commands
  (:func:`drx.evaluate.action_space.racing_line_actions`), or :data:`CONTINUOUS`
  (``race-pace-continuous``), a box bounded by the steering and speed commands the line asks for.
  ``race-pace`` is the kind that lapped faster in ``benchmarks/race_pace.py --compare-kinds``
  (:data:`RECIPE_KIND`; ``docs/RACING.md``, "The race-pace recipe");
- **the reward**: :mod:`drx.recipes.reward_template`, a normal reward file carrying the line;
- **the algorithm and hyperparameters**: PPO with the settings the racing-line car was measured with
  (:data:`HYPERPARAMETERS`), the learning rate annealed back to the best checkpoint when the laps drift
  (``lr_schedule`` ``anneal``, :mod:`drx.train.anneal`);
- **the stop condition**: 30 minutes (:data:`STOP_CONDITIONS`).

Every choice comes with its reason (:class:`Choice`), which ``drx model show`` lists; any can be
overridden as on any model (``--car``, ``--reward``, ``--algo``, any hyperparameter or stop option), except
that the car must be of the recipe's kind (a continuous recipe with a discrete ``--car`` contradicts it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from drx.errors import DrxError, SettingError
from drx.evaluate.action_space import DEFAULT_ACTIONS, line_commands, racing_line_actions
from drx.evaluate.racing_line import border_polyline, keep_clear, resample
from drx.recipes.reward_template import race_pace_reward
from drx.sim.dynamics import CarParams
from drx.sim.track import Track
from drx.vehicle import CONTINUOUS_SPEED_LIMIT, SPEED_LIMIT, STEERING_LIMIT, Vehicle

DISCRETE = "race-pace-discrete"
CONTINUOUS = "race-pace-continuous"
RECIPE_KIND = CONTINUOUS  # what `race-pace` builds: the kind that measured faster (docs/RACING.md)
RECIPES = {"race-pace": RECIPE_KIND, DISCRETE: DISCRETE, CONTINUOUS: CONTINUOUS}
MAX_STEERING = STEERING_LIMIT  # [deg] DeepRacer's fastest car: full lock ...
MAX_SPEED = SPEED_LIMIT[1]  # [m/s] ... and top speed
BOX_STEERING_MARGIN = 2.0  # [deg] the continuous box reaches this far past the line's sharpest steering
BOX_SPEED_MARGIN = 0.1  # [m/s] ... and below its slowest command
SPEED_SHARE = 0.95  # the reward's target speed: this share of the line's command (grip in reserve)
# PPO as the racing-line car was measured with (docs/RACING.md, "An action space from the racing
# line": 6.80 s best / 6.88 s last on A to Z Speedway after 10 minutes): DeepRacer's published
# experiment's settings (batch 128, learning rate 0.0003, discount 0.995, Huber, 25 episodes, 10 epochs).
HYPERPARAMETERS: dict[str, Any] = {
    "batch_size": 128,
    "learning_rate": 3e-4,
    "discount_factor": 0.995,
    "loss_type": "huber",
    "episodes_per_iteration": 25,
    "num_epochs": 10,
    "lr_schedule": "anneal",
}
STOP_CONDITIONS: dict[str, Any] = {"max_minutes": 30.0}
ALGORITHM = "ppo"


@dataclass(frozen=True)
class Choice:
    """One setting a recipe chose, and why.

    :param setting: what was chosen (``car``, ``reward``, ``algorithm``, a hyperparameter's name...).
    :param value: the choice, in words.
    :param why: the reason, in one sentence.
    :param overridden: the user gave their own value (``value`` is then theirs).
    """

    setting: str
    value: str
    why: str
    overridden: bool = False

    def to_dict(self) -> dict[str, Any]:
        """JSON form (the model's ``recipe`` column)."""
        return {"setting": self.setting, "value": self.value, "why": self.why, "overridden": self.overridden}


@dataclass(frozen=True)
class Recipe:
    """What a recipe builds for one track and direction.

    :param name: the recipe as asked (``race-pace``).
    :param kind: its action space's kind (:data:`DISCRETE` or :data:`CONTINUOUS`).
    :param vehicle: the car.
    :param reward_code: the reward file's code.
    :param reward_filename: the reward file's name.
    :param algorithm: ``ppo``.
    :param hyperparameters: hyperparameter fields it sets.
    :param stop_conditions: stop-condition fields it sets.
    :param choices: every choice with its reason, in the order ``drx model show`` lists them.
    """

    name: str
    kind: str
    vehicle: Vehicle
    reward_code: str
    reward_filename: str
    algorithm: str
    hyperparameters: dict[str, Any]
    stop_conditions: dict[str, Any]
    choices: tuple[Choice, ...] = field(default_factory=tuple)

    def to_dict(self) -> dict[str, Any]:
        """JSON form (the model's ``recipe`` column)."""
        return {"name": self.name, "kind": self.kind, "choices": [c.to_dict() for c in self.choices]}


def check_recipe(name: str) -> str:
    """The kind of car the recipe ``name`` builds.

    :raises SettingError: no such recipe.
    """
    if name not in RECIPES:
        raise SettingError(
            "{field} {value!r} is not a recipe drx has; use {allowed}.",
            "recipe",
            value=name,
            allowed=", ".join(RECIPES),
        )
    return RECIPES[name]


def build_recipe(name: str, track: Track, track_label: str, simulator: str, model_name: str) -> Recipe:
    """The recipe ``name`` for ``track`` in its driving direction, on ``simulator``'s car.

    :param name: a recipe (:data:`RECIPES`).
    :param track: the track's geometry, in the direction it is driven.
    :param track_label: how the track is named to the user (route id and direction).
    :param simulator: the DeepRacer simulator whose car the line is solved for (``"5"``, ``"6"``).
    :param model_name: the model's name (the car is named after it).
    :raises SettingError: an unknown recipe.
    :raises DrxError: the track has no racing line this car can drive (its hairpins are tighter than
        30 degrees of lock can turn), or too few distinct commands for the actions.
    """
    kind = check_recipe(name)
    car = CarParams.for_simulator(simulator)
    car_name = f"{model_name}-car"[:64]
    try:
        lap, steering, commands = line_commands(track, MAX_STEERING, MAX_SPEED, car, car_name)
    except DrxError as exc:
        raise DrxError(f"Track {track_label} has no racing line the recipe can use: {exc}") from None
    if kind == DISCRETE:
        try:
            space = racing_line_actions(
                track, DEFAULT_ACTIONS, MAX_STEERING, MAX_SPEED, car, car_name=car_name
            )
        except DrxError:  # the line's commands are too few to cluster (a straight)
            raise DrxError(
                f"The racing line of {track_label} asks for too few distinct commands for the recipe's "
                f"{DEFAULT_ACTIONS} actions; use --recipe {CONTINUOUS}."
            ) from None
        vehicle = Vehicle(name=car_name, actions=space.actions)
        car_why = (
            f"{DEFAULT_ACTIONS} actions clustered from the commands drx's racing line asks for on this track "
            f"(straight ahead at {MAX_SPEED:g} m/s and the sharpest steering each way kept); every point of "
            f"the line is within {space.largest_miss()[0]:.1f} degrees of an action"
        )
    else:
        vehicle = Vehicle(
            name=car_name, continuous=True, steering_range=line_box_steering(steering),
            speed_range=line_box_speed(commands),
        )  # fmt: skip
        car_why = "a continuous box bounded by the steering and speed commands drx's racing line asks for"
    points = _line_points(track, lap.line.points, commands, car)
    lap_time = float(lap.flying_lap_time if lap.line.closed else lap.estimate_time)
    filename = f"race_pace_{track.name}.py"
    code = race_pace_reward(
        track_label, vehicle.summary(), simulator, points, lap_time, track.closed, speed_share=SPEED_SHARE
    )
    choices = (
        Choice("car", vehicle.summary(), car_why + f", for simulator {simulator}'s car."),
        Choice(
            "action space",
            "discrete" if kind == DISCRETE else "continuous",
            "the kind that lapped faster with this recipe in benchmarks/race_pace.py --compare-kinds"
            if name == "race-pace"
            else f"asked for with --recipe {name}.",
        ),
        Choice(
            "reward",
            filename,
            f"pays for holding the racing line at its speed (its lap {lap_time:.2f} s), times the pace, so a "
            "slower lap never earns more; `drx reward show MODEL` prints it.",
        ),
        Choice(
            "algorithm", ALGORITHM.upper(), "PPO trains about 400 steps a second on a core, SAC about 30."
        ),
        *(Choice(key, _shown(value), HYPERPARAMETER_WHY[key]) for key, value in HYPERPARAMETERS.items()),
        Choice(
            "stop conditions",
            f"{STOP_CONDITIONS['max_minutes']:g} minutes",
            "the time benchmarks/race_pace.py measures the recipe in.",
        ),
    )
    return Recipe(
        name=name,
        kind=kind,
        vehicle=vehicle,
        reward_code=code,
        reward_filename=filename,
        algorithm=ALGORITHM,
        hyperparameters=dict(HYPERPARAMETERS),
        stop_conditions=dict(STOP_CONDITIONS),
        choices=choices,
    )


HYPERPARAMETER_WHY = {
    "batch_size": "DeepRacer's published experiment's, with which the racing-line car was measured.",
    "learning_rate": "DeepRacer's default; the anneal schedule lowers it when the laps drift.",
    "discount_factor": "a horizon of about 200 steps (13 s), most of a lap: the pace pays off within it.",
    "loss_type": "DeepRacer's default for PPO.",
    "episodes_per_iteration": "DeepRacer's published experiment's: 25 episodes start round the whole lap.",
    "num_epochs": "DeepRacer's default.",
    "lr_schedule": "back to the best checkpoint at half the rate when 3 evaluations in a row lap slower "
    "than 1.05x the best, so the last checkpoint keeps the best's pace.",
}


def _shown(value: Any) -> str:
    return f"{value:g}" if isinstance(value, float) else str(value)


def line_box_steering(steering: np.ndarray) -> tuple[float, float]:
    """[deg] A continuous car's steering range bounded by the line's steering commands (with a margin),
    straight ahead always inside it (as the discrete car keeps a straight-ahead action)."""
    low = max(-MAX_STEERING, math.floor(min(0.0, float(np.min(steering))) - BOX_STEERING_MARGIN))
    high = min(MAX_STEERING, math.ceil(max(0.0, float(np.max(steering))) + BOX_STEERING_MARGIN))
    return float(low), float(high)


def line_box_speed(commands: np.ndarray) -> tuple[float, float]:
    """[m/s] A continuous car's speed range bounded by the line's speed commands (with a margin)."""
    low = max(CONTINUOUS_SPEED_LIMIT[0], round(float(np.min(commands)) - BOX_SPEED_MARGIN, 1))
    high = min(CONTINUOUS_SPEED_LIMIT[1], round(float(np.max(commands)), 2))
    return float(low), float(max(high, low + 0.1))


def _line_points(
    track: Track, line: np.ndarray, commands: np.ndarray, car: CarParams
) -> list[tuple[float, float, float]]:
    """The line resampled to one point per track waypoint (as ``params["racing_line"]``,
    :func:`drx.evaluate.theoretical_lap.racing_line_waypoints`), each with the command of its nearest
    line point."""
    count = len(track.center) - (1 if track.closed else 0)
    half_width = 0.5 * car.track_width  # the simulator's own car, as the line was solved for
    borders = (border_polyline(track.inner, track.closed), border_polyline(track.outer, track.closed))
    points = keep_clear(resample(line, track.closed, count), borders, half_width, track.closed)
    nearest = np.argmin(((points[:, None, :] - line[None, :, :]) ** 2).sum(axis=2), axis=1)
    return [(float(x), float(y), float(commands[j])) for (x, y), j in zip(points, nearest, strict=True)]
