"""drx's car fitted to the DART referee: a simulator version without published logs (version 6).

No log of deepracer-simapp 6 has been published, so its car cannot be fitted to logs as versions 4
and 5 were (:mod:`drx.calibration.fit`). It is fitted to the referee instead
(:mod:`drx.calibration.referee`): windows of the shared logs' own action sequences, started where
the log was, are driven by simapp 6's car in DART under version 6's controller laws, and drx's car,
started alike, is fitted to end where the referee's did: the reference point's distance after 5, 10
and 15 steps plus the heading after 15 (scipy's ``least_squares``, soft-L1 loss), the fast windows
(mean command >= 2.5 m/s) weighed as the version-5 fit weighs them. Every constant of
:data:`drx.calibration.fit.PARAMETERS` is fitted within its bounds but the wheels' speed limit, held
at simapp's 100 rad/s x 0.035 m = 3.5 m/s (version 6 keeps the URDF's joint velocity limit).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from drx.calibration.fit import CHECK_STEPS, HEADING_WEIGHT, PARAMETERS
from drx.calibration.referee import RefereeWindow, WindowBatch, distances, median_p90_cm, reference_points
from drx.calibration.replay import FAST_COMMAND
from drx.sim.dynamics import CarParams

HELD = {"wheel_speed_limit": 3.5}  # [m/s] the URDF's velocity="100" rad/s x simapp's 0.035 m
FAST_WEIGHT = 2.0  # as version 5's fit (drx.calibration.fit.FAST_WEIGHT)


@dataclass
class RefereeFit:
    """One fit's car and figures."""

    car: CarParams
    names: list[str]
    evaluations: int
    seconds: float
    before_cm: tuple[float, float]
    after_cm: tuple[float, float]


def fit_to_referee(
    wins: Sequence[RefereeWindow],
    target: np.ndarray,
    start: CarParams,
    max_evaluations: int = 60,
    verbose: int = 0,
) -> RefereeFit:
    """Fit drx's car to the referee's origin poses ``target`` ``(windows, steps, 3)`` over ``wins``,
    starting from ``start`` (see the module docstring)."""
    batch = WindowBatch(wins)
    names = [n for n in PARAMETERS if n not in HELD]
    lower = np.array([PARAMETERS[n][0] for n in names])
    upper = np.array([PARAMETERS[n][1] for n in names])
    x0 = np.clip(np.array([getattr(start, n) for n in names], dtype=float), lower, upper)
    base = start.with_values(**HELD)
    weight = np.where(np.array([w.mean_command for w in wins]) >= FAST_COMMAND, np.sqrt(FAST_WEIGHT), 1.0)
    target_ref = reference_points(target)
    steps = list(CHECK_STEPS)

    def car_for(x: np.ndarray) -> CarParams:
        return base.with_values(**{n: float(v) for n, v in zip(names, x, strict=True)})

    def residuals(x: np.ndarray) -> np.ndarray:
        driven = batch.drive(car_for(x))
        d = (reference_points(driven) - target_ref)[:, steps, :]  # (W, 3 steps, 2)
        heading = np.angle(np.exp(1j * (driven[:, -1, 2] - target[:, -1, 2])))
        parts = [d.reshape(len(wins), -1), HEADING_WEIGHT * heading[:, None]]
        return (np.concatenate(parts, axis=1) * weight[:, None]).ravel()

    started = time.perf_counter()
    before = summary_cm(batch.drive(base), target)
    result = least_squares(residuals, x0, bounds=(lower, upper), loss="soft_l1", f_scale=0.05,
                           max_nfev=max_evaluations, x_scale="jac", verbose=verbose)  # fmt: skip
    car = car_for(result.x)
    return RefereeFit(car, names, int(result.nfev), time.perf_counter() - started, before,
                      summary_cm(batch.drive(car), target))  # fmt: skip


def summary_cm(driven: np.ndarray, target: np.ndarray) -> tuple[float, float]:
    """Median and 90th percentile [cm] of the reference points' distance after the last step."""
    return median_p90_cm(distances(driven, target)[:, -1])
