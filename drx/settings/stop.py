"""A model's stop conditions: when a training run ends (checked by :mod:`drx.train.stop`).

``max_minutes`` (DeepRacer allows 10-1440; drx trains in minutes on a laptop, so it accepts
1-1440), ``max_steps`` and ``max_episodes`` (``None`` = no limit) and ``target_iterations``: stop
once every evaluation episode of K iterations in a row reached 100% progress (``None`` = off).
Training stops at whichever comes first. A model stores :meth:`StopConditions.to_dict` as its
``stop_conditions`` JSON; a training job's ``options["stop"]`` holds the ones ``drx train``
overrides (:meth:`StopConditions.overridden`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import Any

from drx.errors import SettingError

MAX_MINUTES_RANGE = (1, 1440)  # [min] DeepRacer: 10-1440
DEFAULT_MAX_MINUTES = 60  # DeepRacer's default
TARGET_ITERATIONS_RANGE = (1, 100)


@dataclass(frozen=True)
class StopConditions:
    """When a training run ends.

    Built from stored JSON (:meth:`from_dict`) the values are taken as they are (tests train for
    seconds); values a user gives go through :meth:`overridden`, which checks them.

    :param max_minutes: wall-clock training minutes (this model's total, across resumed attempts).
    :param max_steps: environment steps in training episodes.
    :param max_episodes: training episodes.
    :param target_iterations: stop after K iterations in a row whose evaluation laps all reached 100%.
    """

    max_minutes: float | None = float(DEFAULT_MAX_MINUTES)
    max_steps: int | None = None
    max_episodes: int | None = None
    target_iterations: int | None = None

    @classmethod
    def from_dict(cls, d: dict[str, Any] | None) -> StopConditions:
        """Read a model's ``stop_conditions`` JSON (unknown keys are ignored; a missing
        ``max_minutes`` is the default, a ``None`` one no time limit)."""
        d = d or {}
        return cls(
            max_minutes=_opt_float(d.get("max_minutes", DEFAULT_MAX_MINUTES)),
            max_steps=_opt_int(d.get("max_steps")),
            max_episodes=_opt_int(d.get("max_episodes")),
            # "target" is the key's name in models stored before it was renamed
            target_iterations=_opt_int(d["target_iterations"] if d.get("target_iterations") is not None
                                       else d.get("target")),  # fmt: skip
        )

    def to_dict(self) -> dict[str, Any]:
        """The JSON form."""
        return {key: getattr(self, key) for key in STOP_KEYS}

    def overridden(self, overrides: dict[str, Any] | None) -> StopConditions:
        """A copy with the non-``None`` ``overrides`` (a user's values, checked) in place.

        :raises SettingError: an override is out of range.
        """
        given = {k: v for k, v in (overrides or {}).items() if k in STOP_KEYS and v is not None}
        check_stop_values(given)
        return replace(self, **given)

    def describe(self) -> str:
        """One line such as ``60 min, 100000 steps, 3 full-lap iterations in a row``."""
        parts = [f"{self.max_minutes:g} min"] if self.max_minutes is not None else ["no time limit"]
        if self.max_steps:
            parts.append(f"{self.max_steps} steps")
        if self.max_episodes:
            parts.append(f"{self.max_episodes} episodes")
        if self.target_iterations:
            parts.append(f"{self.target_iterations} full-lap iterations in a row")
        return ", ".join(parts)


# The four stop-condition keys, in one place (the JSON's keys, the CLI's options, the job's overrides).
STOP_KEYS = tuple(f.name for f in fields(StopConditions))


def check_stop_values(given: dict[str, Any]) -> None:
    """Check stop-condition values a user gives (``None`` values are not given).

    :raises SettingError: naming the first value out of range.
    """
    if given.get("max_minutes") is not None:
        lo, hi = MAX_MINUTES_RANGE
        value = given["max_minutes"]
        if not (math.isfinite(value) and lo <= value <= hi):
            raise SettingError(
                "{field} {value:g} is out of range; use {lo} to {hi} minutes "
                "(DeepRacer allows 10 to 1440; drx also accepts shorter runs).",
                "max_minutes",
                value=value,
                lo=lo,
                hi=hi,
            )
    for key in ("max_steps", "max_episodes"):
        if given.get(key) is not None and given[key] < 1:
            raise SettingError(
                "{field} {value} is out of range; use a whole number of at least 1.", key, value=given[key]
            )
    if given.get("target_iterations") is not None:
        lo, hi = TARGET_ITERATIONS_RANGE
        if not lo <= given["target_iterations"] <= hi:
            raise SettingError(
                "{field} {value} is out of range; use {lo} to {hi}.",
                "target_iterations",
                value=given["target_iterations"],
                lo=lo,
                hi=hi,
            )


def _opt_float(v: Any) -> float | None:
    return None if v is None else float(v)


def _opt_int(v: Any) -> int | None:
    return None if v is None else int(v)
