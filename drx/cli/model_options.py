"""The options ``drx model create`` and ``drx model clone`` share, declared once.

:func:`model_options` adds them to a command (as sqlite-utils' ``output_options`` does) and hands
the command one :class:`ModelOptions` instead of two dozen parameters; :func:`stop_options` adds
only the stop conditions (``drx train``'s overrides for one job). The help of each
hyperparameter is :data:`drx.settings.hyperparameters.HELP`; each option's flag is the CLI's
flag for its field (:data:`drx.cli.flags.FLAGS`), so an error naming the field names this option.
"""

from __future__ import annotations

import functools
import inspect
from collections.abc import Callable
from dataclasses import dataclass
from typing import Annotated, Any, TypeVar

import typer

from drx.cli.flags import flag
from drx.settings.car import DEFAULT_SIMULATOR, SIMULATOR_HELP
from drx.settings.device import DEVICE_HELP
from drx.settings.episodes import DEEPRACER_KEYS
from drx.settings.hyperparameters import HELP
from drx.settings.stop import DEFAULT_MAX_MINUTES, MAX_MINUTES_RANGE, TARGET_ITERATIONS_RANGE

F = TypeVar("F", bound=Callable[..., Any])

HYPERPARAMETERS: dict[str, type] = {
    "batch_size": int,
    "num_epochs": int,
    "learning_rate": float,
    "entropy": float,
    "discount_factor": float,
    "loss_type": str,
    "episodes_per_iteration": int,
    "sac_alpha": float,
    "lr_schedule": str,
    "towers": str,
}
STOP_HELP = {
    "max_minutes": f"Stop after this many minutes, {MAX_MINUTES_RANGE[0]}-{MAX_MINUTES_RANGE[1]}",
    "max_steps": "Stop after this many training steps",
    "max_episodes": "Stop after this many training episodes",
    "target_iterations": "Stop once evaluation laps reach 100% progress for this many iterations in a row "
    f"({TARGET_ITERATIONS_RANGE[0]}-{TARGET_ITERATIONS_RANGE[1]})",
}
STOP_TYPES: dict[str, type] = {
    "max_minutes": float,
    "max_steps": int,
    "max_episodes": int,
    "target_iterations": int,
}
RACE_OPTIONS: dict[str, tuple[Any, Any, str]] = {  # name: (type, default, help)
    "race_type": (
        str | None,
        None,
        "time-trial, object-avoidance, head-to-bot or head-to-model [default: time-trial].",
    ),
    "objects": (int | None, None, "Object avoidance: boxes on the track, 1-6 [default: 3]."),
    "object_at": (
        list[str] | None,
        None,
        "Object avoidance: a box at PLACE:LANE, e.g. 25:inside (percent of the lap 7-90, "
        "inside|outside); repeat per box, at least 13% apart.",
    ),
    "randomize_objects": (bool, False, "Object avoidance: new random box places every training episode."),
    "bots": (int | None, None, "Head-to-bot: bot cars, 1-4 [default: 3]."),
    "bot_speed": (float | None, None, "Head-to-bot: bot speed, 0.2-6 m/s [default: 0.2]."),
    "bot_lane_change": (bool, False, "Head-to-bot: bots change lanes every 3-5 s."),
    "randomize_bots": (bool, False, "Head-to-bot: new random bot places and lanes every training episode."),
    "opponent": (
        list[str] | None,
        None,
        "Head-to-model: a trained model (same track and direction) whose best checkpoint drives another "
        "car in every training episode; repeat for 2-3.",
    ),
}

# name: (type, help, flag declarations); the defaults are DeepRacer's, and a clone's its parent's
EPISODE_OPTIONS: dict[str, tuple[Any, str, tuple[str, ...]]] = {
    "alternate_direction": (
        bool | None,
        f"Each training episode the other way round ({DEEPRACER_KEYS['alternate_direction']}); "
        "loops only [default: off; a clone: its parent's].",
        ("--alternate-direction/--no-alternate-direction",),
    ),
    "change_start_position": (
        bool | None,
        f"Round-robin starts: each training episode starts further along the lap "
        f"({DEEPRACER_KEYS['change_start_position']}); off: every episode at --start-position-offset "
        "[default: on; a clone: its parent's].",
        ("--change-start-position/--no-change-start-position",),
    ),
    "round_robin_advance": (
        float | None,
        f"Fraction of the lap the start moves on after each episode, 0 < F < 1 "
        f"({DEEPRACER_KEYS['round_robin_advance']}) [default: 0.05; a clone: its parent's].",
        (flag("round_robin_advance"),),
    ),
    "start_position_offset": (
        float | None,
        f"Fraction of the lap where the first episode starts, 0 <= F < 1 "
        f"({DEEPRACER_KEYS['start_position_offset']}) [default: 0; a clone: its parent's].",
        (flag("start_position_offset"),),
    ),
}
DIRECTION_HELP = (
    "cw or ccw (clockwise, counter-clockwise): drive the track(s) that way, as the console's "
    "direction: a two-way track's _cw/_ccw route, else the route reversed (training and the model's "
    "default evaluation) [default: each route's own; a clone without --track: its parent's]."
)


@dataclass(frozen=True)
class ModelOptions:
    """What the shared options gave, in the service layer's terms.

    :param hyperparameters: :class:`~drx.settings.hyperparameters.Hyperparameters` overrides
        (``None``: not given).
    :param stop_conditions: :class:`~drx.settings.stop.StopConditions` overrides (``None``: not given).
    :param race: :class:`~drx.settings.race.RaceConfig` fields, or ``None`` when no race option was given.
    :param description: a note about the model.
    :param rollout_workers: processes sampling training episodes (``None``: not given).
    :param check_reward: check the reward on sample states (``--force`` turns it off).
    :param direction: ``--direction`` as typed (``None``: not given).
    :param episodes: where episodes start (:data:`drx.settings.episodes.OPTION_KEYS`; ``None``
        values: not given).
    :param device: the torch device it trains on, as typed (``None``: not given).
    :param simulator: the DeepRacer simulator whose car it trains on, as typed (``None``: not given).
    :param car_randomization: ``--car-randomization`` / ``--no-car-randomization`` (``None``: not given).
    """

    hyperparameters: dict[str, Any]
    stop_conditions: dict[str, Any]
    race: dict[str, Any] | None
    description: str | None
    rollout_workers: int | None
    check_reward: bool
    direction: str | None = None
    episodes: dict[str, Any] | None = None
    device: str | None = None
    simulator: str | None = None
    car_randomization: bool | None = None


def _option(name: str, kind: Any, default: Any, help_text: str, *decls: str) -> inspect.Parameter:
    return inspect.Parameter(
        name,
        inspect.Parameter.KEYWORD_ONLY,
        default=default,
        annotation=Annotated[kind, typer.Option(*decls, help=help_text)],
    )


def _stop_parameters(defaults: dict[str, str]) -> list[inspect.Parameter]:
    """The stop-condition options; ``defaults``: the note on each one's default, by field."""
    return [
        _option(f, t | None, None, f"{STOP_HELP[f]} [{defaults.get(f, 'default: no limit')}].", flag(f))
        for f, t in STOP_TYPES.items()
    ]


PARAMETERS = [
    *(_option(f, t | None, None, HELP[f], flag(f)) for f, t in HYPERPARAMETERS.items()),
    *_stop_parameters(
        {"max_minutes": f"default: {DEFAULT_MAX_MINUTES}", "target_iterations": "default: off"}
    ),
    _option("description", str | None, None, "A note about the model.", "--description"),
    *(_option(name, kind, default, text) for name, (kind, default, text) in RACE_OPTIONS.items()),
    _option(
        "force",
        bool,
        False,
        "Keep a reward function that fails `drx reward validate`'s sample states (checked by "
        "default: training would fail on it).",
        "--force",
    ),
    _option(
        "rollout_workers",
        int | None,
        None,
        "Processes sampling training episodes, 1-64 [default: as many as help where it trains].",
        flag("rollout_workers"),
    ),
    _option("direction", str | None, None, DIRECTION_HELP, flag("direction")),
    _option(
        "device",
        str | None,
        None,
        f"Train on {DEVICE_HELP} [default: auto; a clone: its parent's].",
        flag("device"),
    ),
    *(_option(name, kind, None, text, *decls) for name, (kind, text, decls) in EPISODE_OPTIONS.items()),
    _option(
        "simulator",
        str | None,
        None,
        f"The DeepRacer simulator whose car it trains and races on: {SIMULATOR_HELP} "
        f"[default: {DEFAULT_SIMULATOR}, where DeepRacer races now; a clone: its parent's].",
        flag("simulator"),
    ),
    _option(
        "car_randomization",
        bool | None,
        None,
        "Each training episode draws a car between simulator 5's and 6's (steering lag, mass, grip, "
        "speed), so the model races on either [default: off; a clone: its parent's].",
        "--car-randomization/--no-car-randomization",
    ),
]


def _race(given: dict[str, Any]) -> dict[str, Any] | None:
    """The race options as RaceConfig fields; ``None`` when none was given."""
    from drx.settings.race import parse_object_at

    if all(given[name] in (None, False, []) for name in RACE_OPTIONS):
        return None
    return {
        **{name: given[name] for name in RACE_OPTIONS if name not in ("object_at", "opponent")},
        "opponents": list(given["opponent"] or ()),
        "race_type": given["race_type"] or "time-trial",
        "object_positions": [parse_object_at(p) for p in given["object_at"] or ()],
    }


def collect(given: dict[str, Any]) -> ModelOptions:
    """The shared options' values (keyed by parameter name) as :class:`ModelOptions`."""
    return ModelOptions(
        hyperparameters={f: given[f] for f in HYPERPARAMETERS},
        stop_conditions={f: given[f] for f in STOP_TYPES},
        race=_race(given),
        description=given["description"],
        rollout_workers=given["rollout_workers"],
        check_reward=not given["force"],
        direction=given["direction"],
        episodes={name: given[name] for name in EPISODE_OPTIONS},
        device=given["device"],
        simulator=given["simulator"],
        car_randomization=given["car_randomization"],
    )


def option_bundle(
    parameters: list[inspect.Parameter], name: str, collect: Callable[[dict[str, Any]], Any]
) -> Callable[[F], F]:
    """A decorator adding ``parameters`` (Typer options) to a command, which receives
    ``collect(their values by name)`` as its keyword argument ``name`` instead."""

    def decorate(command: F) -> F:
        hints = dict(inspect.get_annotations(command, eval_str=True))
        signature = inspect.signature(command, eval_str=True)
        own = [p for p in signature.parameters.values() if p.name != name]

        @functools.wraps(command)
        def wrapper(*args: Any, **kwargs: Any) -> Any:
            given = {p.name: kwargs.pop(p.name) for p in parameters}
            return command(*args, **{name: collect(given)}, **kwargs)

        hints.pop(name, None)
        wrapper.__signature__ = signature.replace(parameters=[*own, *parameters])  # type: ignore[attr-defined]
        wrapper.__annotations__ = {**hints, **{p.name: p.annotation for p in parameters}}
        return wrapper  # type: ignore[return-value]

    return decorate


model_options = option_bundle(PARAMETERS, "options", collect)
model_options.__doc__ = (
    "Add the shared model options to a command, which takes them as ``options: ModelOptions``."
)

STOP_PARAMETERS = _stop_parameters({f: "default: the model's" for f in STOP_TYPES})
stop_options = option_bundle(STOP_PARAMETERS, "stop", lambda given: {f: given[f] for f in STOP_TYPES})
stop_options.__doc__ = "Add the stop-condition options to a command, which takes them as ``stop: dict``."
