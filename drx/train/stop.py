"""Stop conditions, checked inside the trainer after every step and every iteration.

A model's ``stop_conditions`` (:class:`drx.settings.stop.StopConditions`) are
``max_minutes``, ``max_steps``, ``max_episodes`` and ``target_iterations`` (K):
training stops at whichever comes first, and the reason is recorded on the job.
Besides these, a run stops when someone asks it to (``drx jobs stop``, Ctrl-C).
"""

from __future__ import annotations

import time

from drx.errors import Interruption
from drx.settings.stop import StopConditions

# Reasons, as recorded on the job (``jobs.stop_reason``).
MAX_MINUTES = "max_minutes"
MAX_STEPS = "max_steps"
MAX_EPISODES = "max_episodes"
TARGET = "target"
REQUESTED = "requested"
INTERRUPTED = "interrupted"

OVERSHOOT_SECONDS = 20.0  # [s] a run may end this much past max_minutes (or 10% of it, if more)


class StopRequested(Interruption):
    """Raised inside a slow reward call when someone asks the run to stop (``drx jobs stop``);
    the trainer drops the iteration in progress and stops, keeping the last checkpoint."""


class StopWatch:
    """Tracks a run against its :class:`StopConditions`.

    Counters start from the values a resumed run already had (``elapsed``,
    ``steps``, ``episodes``, ``streak``), so limits hold across attempts.

    :param conditions: the limits.
    :param elapsed: training seconds already spent.
    :param steps: training steps already taken.
    :param episodes: training episodes already run.
    :param streak: iterations in a row already at 100% evaluation progress.
    """

    def __init__(
        self,
        conditions: StopConditions,
        elapsed: float = 0.0,
        steps: int = 0,
        episodes: int = 0,
        streak: int = 0,
    ) -> None:
        self.conditions = conditions
        self._elapsed_before = elapsed
        self._started = time.monotonic()
        self.steps = steps
        self.episodes = episodes
        self.streak = streak
        self.reason: str | None = None

    def start(self, at: float | None = None) -> None:
        """Start the clock at ``at`` (a ``time.monotonic()`` value: when the job started), else now."""
        self._started = time.monotonic() if at is None else float(at)

    @property
    def elapsed(self) -> float:
        """Training seconds so far, this attempt included."""
        return self._elapsed_before + time.monotonic() - self._started

    def remaining_seconds(self) -> float | None:
        """Seconds left before ``max_minutes`` (``None`` without a time limit)."""
        if self.conditions.max_minutes is None:
            return None
        return max(0.0, self.conditions.max_minutes * 60.0 - self.elapsed)

    def progress(self) -> float | None:
        """How far the run is toward its first limit (minutes, steps or episodes), 0 to 1;
        ``None`` when it has none of them (``target_iterations`` cannot be foreseen)."""
        c = self.conditions
        limits = (
            (self.elapsed, None if c.max_minutes is None else c.max_minutes * 60.0),
            (self.steps, c.max_steps),
            (self.episodes, c.max_episodes),
        )
        shares = [spent / limit for spent, limit in limits if limit]
        return min(1.0, max(shares)) if shares else None

    def overshoot_allowed(self) -> float | None:
        """[s] how far past ``max_minutes`` a run may end: 10% of the limit or 20 s, the larger."""
        if self.conditions.max_minutes is None:
            return None
        return max(0.1 * self.conditions.max_minutes * 60.0, OVERSHOOT_SECONDS)

    def past_limit(self, margin: float = 0.0) -> bool:
        """Whether the time used is ``margin`` seconds or more past ``max_minutes``."""
        c = self.conditions
        return c.max_minutes is not None and self.elapsed >= c.max_minutes * 60.0 + margin

    def check_limits(self) -> str | None:
        """The first limit reached (minutes, steps, episodes), or ``None``; remembered in :attr:`reason`."""
        c = self.conditions
        if self.reason is None:
            if c.max_steps is not None and self.steps >= c.max_steps:
                self.reason = MAX_STEPS
            elif c.max_episodes is not None and self.episodes >= c.max_episodes:
                self.reason = MAX_EPISODES
            elif c.max_minutes is not None and self.elapsed >= c.max_minutes * 60.0:
                self.reason = MAX_MINUTES
        return self.reason

    def record_evaluation(self, all_laps_complete: bool) -> str | None:
        """Count an iteration's evaluation toward the target; returns ``target`` once reached."""
        self.streak = self.streak + 1 if all_laps_complete else 0
        target = self.conditions.target_iterations
        if self.reason is None and target is not None and self.streak >= target:
            self.reason = TARGET
        return self.reason

    def request(self, reason: str = REQUESTED) -> None:
        """Stop because someone asked (job stop, Ctrl-C)."""
        if self.reason is None:
            self.reason = reason
