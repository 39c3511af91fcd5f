"""A model's stop conditions: when a training run ends (checked by :mod:`drx.train.stop`)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class StopConditions:
    """When a training run ends.

    :param max_minutes: wall-clock training minutes (this model's total, across resumed attempts).
    :param max_steps: environment steps in training episodes.
    :param max_episodes: training episodes.
    :param target_iterations: stop after K iterations in a row whose evaluation laps all reached 100%.
    """

    max_minutes: float | None = 60.0
    max_steps: int | None = None
    max_episodes: int | None = None
    target_iterations: int | None = None

    @classmethod
    def from_dict(cls, d: dict[str, Any] | None) -> StopConditions:
        """Read a model's ``stop_conditions`` JSON (unknown keys are ignored)."""
        d = d or {}
        return cls(
            max_minutes=_opt_float(d.get("max_minutes")),
            max_steps=_opt_int(d.get("max_steps")),
            max_episodes=_opt_int(d.get("max_episodes")),
            target_iterations=_opt_int(d.get("target_iterations") or d.get("target")),
        )

    def to_dict(self) -> dict[str, Any]:
        """The JSON form."""
        return {
            "max_minutes": self.max_minutes,
            "max_steps": self.max_steps,
            "max_episodes": self.max_episodes,
            "target_iterations": self.target_iterations,
        }


def _opt_float(v: Any) -> float | None:
    return None if v is None else float(v)


def _opt_int(v: Any) -> int | None:
    return None if v is None else int(v)
