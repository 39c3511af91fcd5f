"""The variation DeepRacer's simulator has and a perfectly repeatable simulator lacks.

DeepRacer's agent does not read the car on an exact 15 Hz beat: Gazebo runs on
while the agent chooses its action, so the moment each step's pose is taken
(and the next command starts) wanders around the beat. In the shared logs the
distance the car has driven, at a held command, is off a smooth curve in the
step count by 0.06 steps (sd), so a step varies by about 8 % (8.3 % on simapp
5's logs, 8.6 % on the console's: :func:`drx.calibration.step_jitter.step_length_jitter`,
``tools/fit_car_model.py`` writes it as ``CarParams.step_time_jitter``). Whether
the steps are a jittered beat (a long step followed by a short one) or of
independent lengths the logs do not settle: consecutive residuals correlate at
-0.18, between the -0.36 of a pure beat and the -0.09 of independent steps; drx
draws the beat, which keeps the simulated clock in step over a lap. (The logged
``tstamp`` jitters too, by 10 ms, but independently of the car: it is the clock
the agent last heard, not the car's; :mod:`drx.calibration.logs`.)

:class:`StepNoise` reproduces that: step ``j`` lasts ``mean + n[j+1] - n[j]``
with ``n`` normal of sd ``step_time_jitter / sqrt(2)``, so a step's length has sd
``step_time_jitter`` and consecutive steps correlate at -0.5, while a lap's
time drifts by no more than one reading's jitter. The same commands then end a
few centimetres apart after a second, and the three laps of an evaluation differ.
The fit of the car model asks for no other noise: its replay residuals are of that size.

The draws come from a seeded generator (the env's ``np_random``, so
``reset(seed=...)`` makes runs repeatable), in blocks, so a step costs one list
lookup. Lengths are clipped to 0.5-1.5 times the mean.
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
        self._reading: float | None = None  # the last draw of n: the last reading's offset off the beat [s]

    def reseed(self, rng: np.random.Generator) -> None:
        """Draw from ``rng`` from now on (after ``reset(seed=...)``), dropping pre-drawn values."""
        self._rng = rng
        self._block = []
        self._next = 0
        self._reading = None

    def step_time(self) -> float:
        """The next step's length [s]."""
        if not self.enabled:
            return self.nominal
        if self._next >= len(self._block):
            first = self._reading is None  # the first reading is off the beat as much as any
            readings = self.jitter / np.sqrt(2.0) * self._rng.standard_normal(BLOCK + 1)
            if not first:
                readings[0] = self._reading
            self._reading = float(readings[-1])
            draws = self.mean + np.diff(readings)
            self._block = np.clip(draws, 0.5 * self.mean, 1.5 * self.mean).tolist()
            self._next = 0
        dt = self._block[self._next]
        self._next += 1
        return dt
