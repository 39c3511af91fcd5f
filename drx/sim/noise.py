"""The variation DeepRacer's simulator has and a perfectly repeatable simulator lacks.

DeepRacer's steps are not all 1/15 s long: the simulator steps Gazebo for
whatever time passed while the agent chose its action, so the logged
``tstamp`` advances by 0.0667 s on average with a spread of about 8.5 ms (the
shared logs, ``tools/fit_car_model.py`` measures it; ``CarParams.step_time`` and
``step_time_jitter``). The car keeps its command for that long, so the same
commands end a few centimetres apart after a second (DEEPRACER.md section 4:
6-8 cm), and the three laps of an evaluation differ. The fit of the car model
asks for no other noise: its replay residuals are of that size.

:class:`StepNoise` draws the step lengths from a seeded generator (the env's
``np_random``, so ``reset(seed=...)`` makes runs repeatable), in blocks, so a
step costs one list lookup. Lengths are clipped to 0.5-1.5 times the mean,
within the range the logs show.
"""

from __future__ import annotations

import numpy as np

from drx.sim.dynamics import CarParams

BLOCK = 4096  # normal draws per refill


class StepNoise:
    """Seeded step lengths: ``step_time()`` returns the next one [s].

    :param car: the car's constants (``step_time``, ``step_time_jitter``, ``rate_hz``).
    :param rng: the generator to draw from.
    :param enabled: ``False``: every step is exactly ``1 / rate_hz`` (the env's ``deterministic``).
    """

    def __init__(self, car: CarParams, rng: np.random.Generator, enabled: bool = True) -> None:
        self.enabled = enabled and car.step_time_jitter > 0.0
        self.nominal = 1.0 / car.rate_hz
        self.mean = car.step_time if enabled else self.nominal
        self.jitter = car.step_time_jitter
        self._rng = rng
        self._block: list[float] = []
        self._next = 0

    def reseed(self, rng: np.random.Generator) -> None:
        """Draw from ``rng`` from now on (after ``reset(seed=...)``), dropping pre-drawn values."""
        self._rng = rng
        self._block = []
        self._next = 0

    def step_time(self) -> float:
        """The next step's length [s]."""
        if not self.enabled:
            return self.nominal
        if self._next >= len(self._block):
            draws = self.mean + self.jitter * self._rng.standard_normal(BLOCK)
            self._block = np.clip(draws, 0.5 * self.mean, 1.5 * self.mean).tolist()
            self._next = 0
        dt = self._block[self._next]
        self._next += 1
        return dt
