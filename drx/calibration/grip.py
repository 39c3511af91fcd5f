"""The grip envelope: the lateral acceleration DeepRacer's car holds at speed, from its logged poses.

The replay windows (:mod:`drx.calibration.replay`) score the car on typical driving; a best lap is made at
the edge of the envelope, where training logs seldom drive. :func:`grip_envelope` measures that edge:
at every logged step where the car runs at ``min_speed`` or more (all rows around it in progress, every
step sane), the lateral acceleration ``v^2 * curvature`` of the car's origin (``reference_ahead`` behind
the logged point), from a quadratic fitted to the positions of the seven steps around it (a
Savitzky-Golay filter on the step count: the logged clock jitters independently of the car,
:mod:`drx.calibration.logs`; a timing jitter moves a point along the path, so it corrupts the along-track
acceleration far more than the lateral one). drx's car replays the same steps: started ``lead`` steps
before, as :func:`drx.calibration.replay.replay` starts a window, driven by the logged commands, its
lateral acceleration read from its own path through the same filter. The figures are percentiles of
``|a|`` per band of logged speed, for every sample and for the *steady* ones (the lateral acceleration
within ``steady_tolerance`` of its value over the three steps either side: turns held, not swerves),
and per band of wheel slip (``(command - speed) / max(command, speed)``, the command the mean of the
step's and the two before): whether the grip falls as the wheels slip (:meth:`CarParams.grip`).

``tools/grip_envelope.py`` prints them per log; ``docs/DYNAMICS.md`` ("The grip envelope") keeps the
figures.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from drx.calibration.logs import LoggedEpisode
from drx.calibration.replay import command_history, drive
from drx.sim.dynamics import CarParams, steady_curvature

SPEED_BANDS = ((1.5, 2.0), (2.0, 2.5), (2.5, 3.0), (3.0, 3.5), (3.5, 4.5))  # [m/s] of the logged speed
SLIP_BANDS = (
    (-1.0, -0.3),
    (-0.3, -0.1),
    (-0.1, 0.05),
    (0.05, 0.15),
    (0.15, 0.3),
    (0.3, 1.0),
)  # wheel slip [-]
# (below 0: the wheels turn slower than the car, braking)
PERCENTILES = (50.0, 90.0, 99.0)
HALF = 3  # the filter's half-width [steps]: 7 positions
# 7-point quadratic Savitzky-Golay weights for the first and second derivative in the step count
_D1 = np.arange(-HALF, HALF + 1) / 28.0
_D2 = np.array([5.0, 0.0, -3.0, -4.0, -3.0, 0.0, 5.0]) / 42.0


@dataclass
class GripSamples:
    """Per sampled step: the logged speed [m/s], wheel slip [-], the logged and drx's lateral
    acceleration [m/s^2] (signed), and whether the logged turn is steady."""

    speed: np.ndarray
    slip: np.ndarray
    log: np.ndarray
    drx: np.ndarray
    steady: np.ndarray

    def __len__(self) -> int:
        return len(self.speed)

    def subset(self, mask: np.ndarray) -> GripSamples:
        return GripSamples(
            self.speed[mask], self.slip[mask], self.log[mask], self.drx[mask], self.steady[mask]
        )

    @staticmethod
    def join(parts: Sequence[GripSamples]) -> GripSamples:
        cat = np.concatenate
        return GripSamples(
            cat([p.speed for p in parts]), cat([p.slip for p in parts]), cat([p.log for p in parts]),
            cat([p.drx for p in parts]), cat([p.steady for p in parts]),
        )  # fmt: skip


def lateral_motion(x: np.ndarray, y: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Speed [m/s] and signed lateral acceleration [m/s^2] at the middle of every 7 consecutive points
    of a path sampled every ``dt`` seconds (``len - 6`` values): ``(v x a) / |v|`` from the filter's
    velocity and acceleration."""
    if len(x) < 2 * HALF + 1:
        return np.empty(0), np.empty(0)
    wx = np.lib.stride_tricks.sliding_window_view(x, 2 * HALF + 1)
    wy = np.lib.stride_tricks.sliding_window_view(y, 2 * HALF + 1)
    vx, vy = wx @ _D1 / dt, wy @ _D1 / dt
    ax, ay = wx @ _D2 / dt**2, wy @ _D2 / dt**2
    speed = np.hypot(vx, vy)
    return speed, (vx * ay - vy * ax) / np.maximum(speed, 1e-6)


def grip_samples(
    episodes: Sequence[LoggedEpisode],
    car: CarParams,
    min_speed: float = 1.5,
    lead: int = 8,
    steady_tolerance: float = 0.25,
    stride: int = 1,
) -> GripSamples:
    """The logged and drx's lateral acceleration at every step driven at ``min_speed`` or more (see the
    module docstring); every ``stride``-th such step."""
    parts = []
    ahead = car.reference_ahead
    for ep in episodes:
        n = len(ep)
        if n < lead + 2 * HALF + 4:
            continue
        ox = ep.x - ahead * np.cos(ep.yaw)
        oy = ep.y - ahead * np.sin(ep.yaw)
        speed, lateral = lateral_motion(ox, oy, ep.step_time)  # index i: row i + HALF
        ok_row = ep.driving.copy()
        ok_row[1:] &= ep.sane_steps
        ok_row[:-1] &= ep.sane_steps
        rows, steady = [], []
        for k in range(max(lead + 2, 2 * HALF), n - 2 * HALF - 1):
            # rows k - lead - 1 .. k + 2 * HALF in progress and evenly stepped
            if not ok_row[k - lead - 1 : k + 2 * HALF + 1].all():
                continue
            i = k - HALF
            if speed[i] < min_speed:
                continue
            around = lateral[i - HALF : i + HALF + 1]
            rows.append(k)
            steady.append(bool(np.all(np.abs(around - lateral[i]) <= steady_tolerance * abs(lateral[i]))))
        rows_a = np.array(rows[::stride], dtype=int)
        if rows_a.size == 0:
            continue
        steady_a = np.array(steady[::stride], dtype=bool)
        history = command_history(ep, car)
        drx = np.empty(len(rows_a))
        for j, k in enumerate(rows_a):
            sim = drive(ep, k - lead, lead + HALF, car, history)  # rows k - lead .. k + HALF
            sx = sim[:, 0] - ahead * np.cos(sim[:, 2])
            sy = sim[:, 1] - ahead * np.sin(sim[:, 2])
            _, a = lateral_motion(sx[-(2 * HALF + 1) :], sy[-(2 * HALF + 1) :], ep.step_time)
            drx[j] = a[0]
        v = speed[rows_a - HALF]
        command = np.mean([ep.throttle[rows_a - d] for d in range(3)], axis=0)
        slip = (command - v) / np.maximum(np.maximum(command, v), 0.1)
        parts.append(GripSamples(v, slip, lateral[rows_a - HALF], drx, steady_a))
    if not parts:
        empty = np.empty(0)
        return GripSamples(empty, empty, empty, empty, np.empty(0, dtype=bool))
    return GripSamples.join(parts)


def car_limit(car: CarParams, speed: float) -> float:
    """The lateral acceleration [m/s^2] drx's car holds at full lock at ``speed`` [m/s] once settled, at
    the command that holds the speed (no wheel slip): :func:`steady_curvature` times ``v^2``."""
    return abs(steady_curvature(car.max_steering, speed, car)) * speed * speed


@dataclass(frozen=True)
class EnvelopeRow:
    """One band's percentiles (:data:`PERCENTILES`) of ``|a|`` [m/s^2], logged and drx's."""

    band: str
    samples: int
    log: tuple[float, ...]
    drx: tuple[float, ...]
    limit: float | None = None


def envelope(samples: GripSamples, car: CarParams | None = None, by: str = "speed",
             steady_only: bool = False) -> list[EnvelopeRow]:  # fmt: skip
    """Percentiles of ``|a|`` per speed band (``by="speed"``, with drx's full-lock limit at the band's
    middle when ``car`` is given) or per wheel-slip band (``by="slip"``)."""
    s = samples.subset(samples.steady) if steady_only else samples
    bands = SPEED_BANDS if by == "speed" else SLIP_BANDS
    values = s.speed if by == "speed" else s.slip
    out = []
    for lo, hi in bands:
        m = (values >= lo) & (values < hi)
        if m.sum() < 20:
            continue
        log = tuple(float(v) for v in np.percentile(np.abs(s.log[m]), PERCENTILES))
        drx = tuple(float(v) for v in np.percentile(np.abs(s.drx[m]), PERCENTILES))
        limit = car_limit(car, 0.5 * (lo + min(hi, 4.0))) if car is not None and by == "speed" else None
        label = f"{lo:g}-{hi:g} m/s" if by == "speed" else f"slip {lo:g}..{hi:g}"
        out.append(EnvelopeRow(label, int(m.sum()), log, drx, limit))
    return out


def lock_radius(
    episodes: Sequence[LoggedEpisode],
    speeds: Sequence[float] = (1.0, 1.5, 2.0, 2.5),
    tolerance: float = 0.2,
    min_steering: float = 27.0,
    hold: int = 7,
    ahead: float = CarParams.reference_ahead,
) -> dict[float, tuple[float, int]]:
    """The radius [m] of the logged turns at near full lock, per speed: at every step where the steering
    command stayed at ``min_steering`` deg or more, to one side, for ``hold`` steps (a continuous action
    space never holds one command exactly, :func:`drx.calibration.replay.held_commands`' test), the
    origin's ``v^2 / |a|`` (:func:`lateral_motion`) where its speed is within ``tolerance`` of one of
    ``speeds``: ``{speed: (median radius, steps)}`` for the speeds with 10 steps or more."""
    found: dict[float, list[float]] = {s: [] for s in speeds}
    for ep in episodes:
        ox = ep.x - ahead * np.cos(ep.yaw)
        oy = ep.y - ahead * np.sin(ep.yaw)
        speed, lateral = lateral_motion(ox, oy, ep.step_time)
        ok = ep.driving.copy()
        ok[1:] &= ep.sane_steps
        ok[:-1] &= ep.sane_steps
        for k in range(max(hold, HALF), len(ep) - HALF - 1):
            steer = ep.steer[k - hold + 1 : k + 1]
            if not ok[k - hold : k + HALF + 1].all() or np.min(np.abs(steer)) < min_steering:
                continue
            if np.ptp(np.sign(steer)) != 0:
                continue
            v, a = speed[k - HALF], abs(lateral[k - HALF])
            for s in speeds:
                if abs(v - s) <= tolerance and a > 1e-6:
                    found[s].append(v * v / a)
    return {s: (float(np.median(r)), len(r)) for s, r in found.items() if len(r) >= 10}
