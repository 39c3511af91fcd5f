"""How much DeepRacer's steps vary in length, read from how far the car moved in its logs.

The logged ``tstamp`` is not the car's clock (:mod:`drx.calibration.logs`), so the variation of
the simulator's steps cannot be read from it. :func:`step_length_jitter` reads it from the distance
the car drives at a held command instead: over runs of a few steps that distance is a smooth curve in
the step count, and what a quadratic fit leaves is how far each moment the car was read wandered off
a steady beat. ``tools/fit_car_model.py`` writes the figure as ``CarParams.step_time_jitter``, which
:mod:`drx.sim.noise` draws from.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from drx.calibration.logs import LoggedEpisode
from drx.sim.dynamics import CarParams


@dataclass(frozen=True)
class StepLengthJitter:
    """How much the car's steps vary in length, from how far it moved (:func:`step_length_jitter`).

    :param relative_sd: standard deviation of a step's length over the mean [-], read as a steady
        beat whose readings jitter (``sqrt(2)`` times ``reading_sd``).
    :param reading_sd: standard deviation of the moments the car is read, about a steady beat, in steps
        [-]: what a quadratic in the step count leaves of the distance driven.
    :param clock_ratio: what a quadratic in the logged time leaves, over ``reading_sd`` [-]: below 1 if
        the logged clock told when the car was read, above 1 if a steady beat tells it better.
    :param lag1: correlation of consecutive residuals of the beat fit [-] (for runs of 8 steps, a pure
        jittered beat gives about -0.36, steps of independent lengths about -0.09).
    :param steps: steps measured.
    """

    relative_sd: float
    reading_sd: float
    clock_ratio: float
    lag1: float
    steps: int


def step_length_jitter(
    episodes: Sequence[LoggedEpisode], run: int = 8, ahead: float = CarParams.reference_ahead
) -> StepLengthJitter:
    """The variation of the car's step lengths, read from the distances it covers.

    In runs of ``run`` steps where the speed command is held (every row in progress, every step sane
    and at least 5 cm long), the distance the car's origin (``ahead`` behind the reference point) has
    driven since the run began is fitted by a quadratic in the step count (a smooth speed read on a
    steady beat) and, for comparison, in the logged time; :func:`beat_jitter` turns the residuals into
    the figures.
    """
    runs: list[tuple[np.ndarray, np.ndarray]] = []
    for ep in episodes:
        origin_x = ep.x - ahead * np.cos(ep.yaw)
        origin_y = ep.y - ahead * np.sin(ep.yaw)
        dist = np.hypot(np.diff(origin_x), np.diff(origin_y))
        j = 0
        while j + run < len(ep):
            span = slice(j, j + run)
            held = np.ptp(ep.throttle[span]) == 0.0 and dist[span].min() >= 0.05
            if held and ep.driving[j : j + run + 1].all() and ep.sane_steps[span].all():
                driven = np.concatenate([[0.0], np.cumsum(dist[span])])
                runs.append((driven, (ep.tstamp[j : j + run + 1] - ep.tstamp[j]) / ep.step_time))
                j += run
            else:
                j += 1
    return beat_jitter(runs)


def beat_jitter(runs: Sequence[tuple[np.ndarray, np.ndarray]]) -> StepLengthJitter:
    """:class:`StepLengthJitter` of runs of ``(distance driven [m], logged time [steps])``, one entry per
    row (distance 0 at the run's first row).

    Read on a steady beat whose readings jitter by ``sigma`` (in steps) the distance is a smooth curve
    in the step count plus ``v * sigma`` noise; a quadratic fit leaves that noise less three degrees of
    freedom per run, so ``reading_sd`` (the residuals over each run's mean step distance) estimates
    ``sigma`` without bias, and a step, the difference of two readings, varies by ``sqrt(2) sigma``."""
    beat_sq = clock_sq = 0.0
    dof = 0
    pairs: list[np.ndarray] = []
    for driven, logged in runs:
        count = np.arange(len(driven), dtype=float)
        step = driven[-1] / (len(driven) - 1)
        beat = (driven - np.polyval(np.polyfit(count, driven, 2), count)) / step
        clock = (driven - np.polyval(np.polyfit(logged, driven, 2), logged)) / step
        beat_sq += float(np.sum(beat**2))
        clock_sq += float(np.sum(clock**2))
        dof += len(driven) - 3
        pairs.append(np.column_stack([beat[:-1], beat[1:]]))
    if dof <= 0:
        return StepLengthJitter(0.0, 0.0, 0.0, 0.0, 0)
    reading = math.sqrt(beat_sq / dof)
    both = np.concatenate(pairs)
    return StepLengthJitter(
        relative_sd=math.sqrt(2.0) * reading,
        reading_sd=reading,
        clock_ratio=math.sqrt(clock_sq / dof) / reading if reading > 0 else math.inf,
        lag1=float(np.corrcoef(both[:, 0], both[:, 1])[0, 1]),
        steps=sum(len(driven) - 1 for driven, _ in runs),
    )
