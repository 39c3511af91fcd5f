"""Hyperparameters and stop conditions of a model, as the CLI gives them.

A model's ``hyperparameters`` JSON is :meth:`drx.settings.hyperparameters.Hyperparameters.to_dict`
(the trainer's one definition of DeepRacer's names, ranges and defaults) plus
``network``, the policy network, always equal to the car snapshot's network.
This module adds what the CLI needs on top: options that do not apply to the
chosen algorithm are refused, and a clone starts from its parent's values.

``stop_conditions`` has ``max_minutes`` (DeepRacer allows 10-1440; drx trains
in minutes on a laptop, so it accepts 1-1440), ``max_steps`` and
``max_episodes`` (``None`` = no limit) and ``target_iterations``: stop once
every evaluation episode of K iterations in a row reached 100% progress
(``None`` = off). Training stops at whichever comes first.
"""

from __future__ import annotations

import math
from typing import Any

from drx.errors import DrxError
from drx.settings.hyperparameters import Hyperparameters

# Hyperparameters field -> CLI option.
OPTION_NAMES = {
    "batch_size": "--batch-size",
    "num_epochs": "--epochs",
    "learning_rate": "--lr",
    "entropy": "--entropy",
    "discount_factor": "--discount",
    "loss_type": "--loss",
    "episodes_per_iteration": "--episodes-per-iteration",
    "sac_alpha": "--sac-alpha",
}
PPO_ONLY = ("num_epochs", "entropy")
SAC_ONLY = ("sac_alpha",)


def default_hyperparameters(algorithm: str, network: str) -> dict[str, Any]:
    """DeepRacer's defaults for ``algorithm`` (``ppo`` or ``sac``), with ``network``."""
    return {**Hyperparameters.default(algorithm).to_dict(), "network": network}


def build_hyperparameters(
    algorithm: str, network: str, overrides: dict[str, Any], base: dict[str, Any] | None = None
) -> dict[str, Any]:
    """Validated hyperparameters: ``base`` (or DeepRacer's defaults) updated with ``overrides``.

    :param algorithm: ``ppo`` or ``sac``.
    :param network: the car's policy network.
    :param overrides: :class:`Hyperparameters` fields to set; ``None`` values are ignored.
    :param base: the starting values (a clone's parent's); ``None`` for the defaults.
    :raises DrxError: a value is out of DeepRacer's range or does not apply to ``algorithm``.
    """
    given = {k: v for k, v in overrides.items() if v is not None}
    for key in PPO_ONLY if algorithm == "sac" else SAC_ONLY:
        if key in given:
            other = "ppo" if algorithm == "sac" else "sac"
            raise DrxError(
                f"{OPTION_NAMES[key]} does not apply to {algorithm.upper()}; use it with --algo {other}."
            )
    if "loss_type" in given and given["loss_type"] not in ("huber", "mse"):
        raise DrxError(f"--loss {given['loss_type']} is unknown; use huber or mse.")
    start = Hyperparameters.from_dict(base, algorithm) if base else Hyperparameters.default(algorithm)
    return {**start.replace(**given).to_dict(), "network": network}


MAX_MINUTES_RANGE = (1, 1440)  # [min] DeepRacer: 10-1440
DEFAULT_MAX_MINUTES = 60  # DeepRacer's default
STOP_DEFAULTS: dict[str, Any] = {
    "max_minutes": DEFAULT_MAX_MINUTES,
    "max_steps": None,
    "max_episodes": None,
    "target_iterations": None,
}
TARGET_ITERATIONS_RANGE = (1, 100)


def build_stop_conditions(overrides: dict[str, Any], base: dict[str, Any] | None = None) -> dict[str, Any]:
    """Validated stop conditions: ``base`` (or the defaults) updated with the non-``None`` ``overrides``.

    :param overrides: any of ``max_minutes``, ``max_steps``, ``max_episodes``, ``target_iterations``.
    :param base: the starting values (a clone's parent's); ``None`` for the defaults.
    :raises DrxError: a value is out of range.
    """
    stop = {**STOP_DEFAULTS, **(base or {})}
    given = {k: v for k, v in overrides.items() if v is not None}
    if "max_minutes" in given:
        lo, hi = MAX_MINUTES_RANGE
        value = given["max_minutes"]
        if not (math.isfinite(value) and lo <= value <= hi):
            raise DrxError(
                f"--max-minutes {value:g} is out of range; use {lo} to {hi} minutes "
                "(DeepRacer allows 10 to 1440; drx also accepts shorter runs)."
            )
    for key, option in (("max_steps", "--max-steps"), ("max_episodes", "--max-episodes")):
        if key in given and given[key] < 1:
            raise DrxError(f"{option} {given[key]} is out of range; use a whole number of at least 1.")
    if "target_iterations" in given:
        lo, hi = TARGET_ITERATIONS_RANGE
        if not lo <= given["target_iterations"] <= hi:
            raise DrxError(
                f"--target-iterations {given['target_iterations']} is out of range; use {lo} to {hi}."
            )
    stop.update(given)
    return stop


def describe_stop_conditions(stop: dict[str, Any]) -> str:
    """One line such as ``60 min, 100000 steps, 3 full-lap iterations in a row``."""
    parts = [f"{stop['max_minutes']:g} min"]
    if stop.get("max_steps"):
        parts.append(f"{stop['max_steps']} steps")
    if stop.get("max_episodes"):
        parts.append(f"{stop['max_episodes']} episodes")
    if stop.get("target_iterations"):
        parts.append(f"{stop['target_iterations']} full-lap iterations in a row")
    return ", ".join(parts)
