"""A model's time trial, checked once and raced by any driver: what an export races on.

``drx model export --for-deepracer`` races the original policy and the exported one on the same
trial. The export (``drx.interchange``) sits below the evaluation layer, so the CLI hands it
:meth:`TimeTrialCourse.for_model`, which it calls as its ``course_for``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from drx.evaluate.service import EvaluationRequest, Prepared, make_env, prepare
from drx.evaluate.time_trial import TrialResult, run_time_trial


@dataclass(frozen=True)
class TimeTrialCourse:
    """A checked time trial of one model's checkpoint (:func:`drx.evaluate.service.prepare`)."""

    prepared: Prepared
    seed: int

    @classmethod
    def for_model(
        cls, model: str, which: str, *, laps: int, seed: int, time_cap_minutes: float
    ) -> TimeTrialCourse:
        """The time trial of model ``model``'s checkpoint ``which`` (best, last or an iteration).

        :raises DrxError: unknown model, no such checkpoint, bad rules.
        """
        request = EvaluationRequest(
            model=model, checkpoint=which, laps=laps, seed=seed, time_cap_minutes=time_cap_minutes
        )
        return cls(prepare(request), seed)

    @property
    def checkpoint_path(self) -> Path:
        """The checkpoint the trial drives (a ``.zip``, or an imported car's ``model.pb``)."""
        return Path(self.prepared.checkpoint.path)

    @property
    def iteration(self) -> int | None:
        """The checkpoint's iteration."""
        return self.prepared.checkpoint.iteration

    def make_env(self) -> Any:
        """A fresh evaluation env of the trial (its track, direction, race and car)."""
        return make_env(self.prepared)

    def race(self, driver: Callable[[Any], Any]) -> TrialResult:
        """Drive the trial with ``driver`` (observation -> action), seeded with the course's seed."""
        return run_time_trial(self.make_env(), driver, self.prepared.rules, seed=self.seed)
