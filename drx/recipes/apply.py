"""A recipe applied to ``drx model create``'s options: what the user gave wins, the recipe fills the rest.

:func:`recipe_arguments` turns ``--recipe`` and the other options into the keyword arguments of
:func:`drx.services.models.create_model`, recording each choice (and whether the user overrode it)
for ``drx model show``. Everything is checked before the model is made: an unknown recipe, a recipe
asked for several tracks, a car of the other kind than the recipe's, a track without a racing line.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from typing import Any

from drx.errors import SettingError
from drx.recipes.race_pace import CONTINUOUS, Choice, Recipe, build_recipe, check_recipe
from drx.services import garage
from drx.services.tracks import find_directed, load_entry
from drx.settings.car import DEFAULT_SIMULATOR, check_simulator
from drx.settings.episodes import DIRECTION_NAMES
from drx.settings.hyperparameters import PPO_ONLY, SAC_ONLY


def recipe_arguments(
    recipe: str,
    model_name: str,
    *,
    tracks: Sequence[str],
    direction: str | None,
    simulator: str | None,
    car: str | None,
    reward: str | None,
    algorithm: str | None,
    hyperparameters: dict[str, Any],
    stop_conditions: dict[str, Any],
) -> dict[str, Any]:
    """:func:`~drx.services.models.create_model`'s arguments for a model built by ``recipe``.

    :param recipe: the recipe's name (:data:`drx.recipes.race_pace.RECIPES`).
    :param model_name: the model's name.
    :param tracks: the ``--track`` values (one).
    :param direction: ``--direction`` (``None``: the route's own).
    :param simulator: ``--simulator`` (``None``: the default).
    :param car: ``--car`` (``None``: the recipe's car); it must be of the recipe's kind.
    :param reward: ``--reward`` (``None``: the recipe's reward).
    :param algorithm: ``--algo`` (``None``: the recipe's).
    :param hyperparameters: the hyperparameter options (``None`` values: not given).
    :param stop_conditions: the stop-condition options (``None`` values: not given).
    :raises SettingError: an unknown recipe, not exactly one track, a ``--car`` of the other kind.
    :raises DrxError: an unknown track or car; a track without a racing line the car can drive.
    """
    kind = check_recipe(recipe)
    if len(tracks) != 1:
        raise SettingError(
            "{recipe} {value} builds a car and a reward for one track and direction; give {field} once.",
            "track",
            "recipe",
            value=recipe,
        )
    own_car = garage.get_vehicle(car) if car is not None else None
    if own_car is not None and own_car.continuous != (kind == CONTINUOUS):
        mine, theirs = ("continuous", "discrete") if kind == CONTINUOUS else ("discrete", "continuous")
        raise SettingError(
            "{recipe} {value} builds a {mine} car, but {field} {name} is {theirs}; give a {mine} car or "
            "leave out {field}.",
            "car",
            "recipe",
            value=recipe,
            mine=mine,
            theirs=theirs,
            name=car,
        )
    directed = find_directed(tracks[0], direction)
    geometry = load_entry(directed.entry)
    if directed.reverse:
        geometry = geometry.reversed()
    version = check_simulator(simulator or DEFAULT_SIMULATOR)
    way = DIRECTION_NAMES.get(directed.direction, "")
    label = (
        f"{directed.entry.name}" + (f", {way}" if way else "") + (" (reversed)" if directed.reverse else "")
    )
    built = build_recipe(recipe, geometry, label, version, model_name)
    given_hp = {k: v for k, v in hyperparameters.items() if v is not None}
    given_stop = {k: v for k, v in stop_conditions.items() if v is not None}
    skip = PPO_ONLY if (algorithm or built.algorithm).lower() == "sac" else SAC_ONLY
    built = replace(built, choices=tuple(c for c in built.choices if c.setting not in skip))
    built = _with_overrides(built, car, reward, algorithm, given_hp, given_stop)
    return {
        "vehicle": None if own_car is not None else built.vehicle,
        "car": car or garage.BUILTIN_CAR,
        "reward": reward or built.reward_filename,
        "reward_code": None if reward is not None else (built.reward_code, built.reward_filename),
        "algorithm": algorithm or built.algorithm,
        "hyperparameters": {
            **_for_algorithm(built.hyperparameters, algorithm or built.algorithm),
            **given_hp,
        },
        "stop_conditions": {**built.stop_conditions, **given_stop},
        "recipe": built.to_dict(),
    }


def _for_algorithm(hyperparameters: dict[str, Any], algorithm: str) -> dict[str, Any]:
    """The recipe's hyperparameters that apply to ``algorithm`` (PPO's epochs are not SAC's)."""
    skip = PPO_ONLY if algorithm.lower() == "sac" else SAC_ONLY
    return {k: v for k, v in hyperparameters.items() if k not in skip}


def _with_overrides(
    built: Recipe,
    car: str | None,
    reward: str | None,
    algorithm: str | None,
    hyperparameters: dict[str, Any],
    stop_conditions: dict[str, Any],
) -> Recipe:
    """The recipe's choices, each the user's value (marked overridden) where they gave one."""
    given: dict[str, str] = {}
    if car is not None:
        given["car"] = car
    if reward is not None:
        given["reward"] = reward
    if algorithm is not None:
        given["algorithm"] = algorithm.upper()
    given.update({k: f"{v:g}" if isinstance(v, float) else str(v) for k, v in hyperparameters.items()})
    if stop_conditions:
        given["stop conditions"] = ", ".join(f"{k} {v:g}" for k, v in stop_conditions.items())
    choices = [
        replace(c, value=given[c.setting], overridden=True) if c.setting in given else c
        for c in built.choices
    ]
    choices += [  # settings the recipe leaves at their defaults, given by the user
        Choice(k, v, "given with the recipe.", overridden=True)
        for k, v in given.items()
        if all(c.setting != k for c in built.choices)
    ]
    return replace(built, choices=tuple(choices))
