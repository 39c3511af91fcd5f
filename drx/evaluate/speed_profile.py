"""The fastest speed profile along a fixed path: the forward-backward method.

Given a path sampled at points ``i`` (segment lengths ``ds_i``, curvatures
``kappa_i``) and the car's limits, the fastest way to drive it is found in
three sweeps (Velenis & Tsiotras 2005; the "forward-backward" or
"quasi-steady-state" lap-time method used throughout motorsport tools):

1. **Cornering.** At each point the speed may not exceed what lets the car
   bend that tightly (:mod:`drx.sim.dynamics`): full steering lock asks for
   ``gain * tan(lock) / wheelbase / (1 + k1 v + k2 v^2)``, a fraction of an
   ideal bicycle's that shrinks with speed as DeepRacer's understeering car's
   does, and the tyres deliver the lateral acceleration that asks for only up
   to grip (:func:`drx.sim.dynamics.tyre_response`: faster, the car runs wide of the line); the
   cap is the fastest speed whose full-lock turn is that tight, and the top
   speed.
2. **Forward (acceleration).** From the slowest point, speeds are carried
   forward: ``v_{i+1} <= v`` reached from ``v_i`` over ``ds_i`` at full
   throttle. Full throttle in drx's motor model is a lag towards the top
   speed whose time constant grows with speed, capped by the motor's
   acceleration: ``dv/dt = min(max_acceleration, (top_speed - v) / (tau0 + tau1 v))``.
3. **Backward (braking).** Speeds are carried backward the same way with the
   braking law ``dv/dt = -min(max_braking, (v - min_command) / (tau0 + tau1 v))``,
   so every corner is entered no faster than the car can brake to.

Both laws are integrated exactly enough in ``u = v^2`` (``du/ds = 2 a``,
fourth-order Runge-Kutta, which has no trouble starting from rest). On a loop
the sweeps start at the slowest grip-limited point, where the speed is known,
and go once around, so the profile is periodic (a *flying* lap). The lap
time is ``sum(2 ds_i / (v_i + v_{i+1}))`` (constant acceleration per segment).

The bound ignores what makes the real car slower: the 15 Hz control, the
steering servo's rate, a discrete action set. It is a lower bound on the lap
time drx's simulator allows for that car, not a promise.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import asdict, dataclass

import numpy as np

from drx.sim.dynamics import slip_command_floor, slip_command_limit, slip_grip, tyre_response

RK_SUBSTEPS = 2  # Runge-Kutta substeps per segment
CRAWL = 1.1  # the slowest cornering speed, as a multiple of the slowest command's steady speed
BISECTIONS = 40  # halvings of the speed range when inverting the turning curvature (to ~1e-11 m/s)


@dataclass(frozen=True)
class SpeedLimits:
    """The car's limits that bound a lap.

    :param top_speed: fastest speed [m/s] (the car's fastest action, within the motor's maximum).
    :param lateral_accel: largest lateral acceleration [m/s^2] (grip * g).
    :param max_acceleration: largest forward acceleration [m/s^2].
    :param max_braking: largest deceleration [m/s^2].
    :param time_constant: first-order lag of the motor at rest [s]; 0 for none.
    :param min_command: the lowest speed the car can reach on its slowest command [m/s] (what
        braking aims at).
    :param max_curvature: tightest path an ideal bicycle with this steering lock drives [1/m]
        (``tan(lock) / wheelbase``); the car model's own is ``steering_gain`` times that at rest.
    :param time_constant_per_speed: growth of the motor's lag with speed [s per m/s].
    :param steering_gain: the car's path curvature as a share of the bicycle's at rest [-].
    :param steering_k1: linear shrink of the steering's effect with speed [s/m] (0: none).
    :param steering_k2: quadratic shrink of the steering's effect with speed [s^2/m^2].
    :param wheelbase: [m], to turn ``max_curvature`` back into a steering lock.
    :param steering_saturation: the effective ``tan(lock)`` saturates towards this [-] (the car
        model's hinge give, ``CarParams.steering_saturation``; infinite: none).
    :param grip_slip: the wheel slip at which the tyres' lateral limit has fallen to ``1/sqrt(2)`` of
        ``lateral_accel`` (``CarParams.grip_slip``; 0: grip does not depend on slip).
    :param tyre_shape: how sharply the tyres' lateral acceleration levels off at grip
        (``CarParams.tyre_shape``, :func:`drx.sim.dynamics.tyre_response`).
    :param speed_gain: steady speed per commanded m/s (``CarParams.speed_gain``), with
        ``speed_offset`` [m/s]: the command that holds a speed, hence the wheels' slip in a steady bend.
    """

    top_speed: float
    lateral_accel: float
    max_acceleration: float
    max_braking: float
    time_constant: float = 0.0
    min_command: float = 0.0
    max_curvature: float = math.inf
    time_constant_per_speed: float = 0.0
    steering_gain: float = 1.0
    steering_k1: float = 0.0
    steering_k2: float = 0.0
    wheelbase: float = 0.164
    steering_saturation: float = math.inf
    grip_slip: float = 0.0
    tyre_shape: float = 2.5
    speed_gain: float = 1.0
    speed_offset: float = 0.0

    @property
    def tightest_curvature(self) -> float:
        """The tightest path the car can drive at all [1/m] (full lock at walking pace)."""
        return self.steering_gain * self.max_curvature

    def accel(self, v: float) -> float:
        """Full-throttle acceleration [m/s^2] at speed ``v`` [m/s]."""
        if v >= self.top_speed:
            return 0.0
        tau = self.time_constant + self.time_constant_per_speed * v
        if tau <= 0:
            return self.max_acceleration
        return min(self.max_acceleration, (self.top_speed - v) / tau)

    def brake(self, v: float) -> float:
        """Full-braking deceleration [m/s^2] (positive) at speed ``v`` [m/s]."""
        tau = self.time_constant + self.time_constant_per_speed * v
        if tau <= 0:
            return self.max_braking
        return min(self.max_braking, max(0.0, (v - self.min_command) / tau))

    def grip(self, speed: np.ndarray) -> np.ndarray:
        """The tyres' lateral limit [m/s^2] at ``speed`` [m/s] under the command that holds it (the car
        model's :meth:`~drx.sim.dynamics.CarParams.grip`)."""
        v = np.asarray(speed, dtype=float)
        command = np.maximum(v - self.speed_offset, 0.0) / self.speed_gain
        return np.asarray(slip_grip(self.lateral_accel, self.grip_slip, v, command), dtype=float)

    def accel_in_bend(self, v: float, curvature: float) -> float:
        """Full-throttle acceleration [m/s^2] at speed ``v`` [m/s] on a path of ``curvature`` [1/m]: the
        throttle held to the highest command whose wheel slip leaves the grip the bend needs
        (:func:`drx.sim.dynamics.slip_command_limit`); negative when even holding speed asks too much."""
        full = self.accel(v)
        command = slip_command_limit(self.lateral_accel, self.grip_slip, curvature, v)
        if not math.isfinite(command):
            return full
        tau = self.time_constant + self.time_constant_per_speed * v
        target = self.speed_gain * command + self.speed_offset
        if tau <= 0:
            return full if target > v else 0.0
        return min(full, (target - v) / tau)

    def brake_in_bend(self, v: float, curvature: float) -> float:
        """Full-braking deceleration [m/s^2] (positive) at speed ``v`` [m/s] on a path of ``curvature``
        [1/m]: the command held no lower than the one whose backward wheel slip leaves the grip the bend
        needs (:func:`drx.sim.dynamics.slip_command_floor`), so braking into a bend is gentler than on
        a straight, as in drx's simulator."""
        full = self.brake(v)
        command = slip_command_floor(self.lateral_accel, self.grip_slip, curvature, v)
        if command <= 0.0:
            return full
        tau = self.time_constant + self.time_constant_per_speed * v
        target = self.speed_gain * command + self.speed_offset
        if tau <= 0:
            return full if target < v else 0.0
        return min(full, max(0.0, (v - target) / tau))

    def turning_curvature(self, speed: np.ndarray) -> np.ndarray:
        """The tightest path [1/m] the car holds at ``speed`` [m/s] on full lock: the steering's reach
        ``gain * max_curvature / (1 + k1 v + k2 v^2)`` (the lock through the hinges' give), saturated
        by grip as the car model's tyres are
        (:func:`drx.sim.dynamics.steady_curvature`, :func:`drx.sim.dynamics.tyre_response`).
        Without a steering limit it is the grip circle's ``lateral_accel / v^2``."""
        v = np.maximum(np.asarray(speed, dtype=float), 1e-9)
        if not math.isfinite(self.max_curvature):
            return self.grip(v) / (v * v)
        shrink = 1.0 + v * (self.steering_k1 + self.steering_k2 * v)
        lock = self.max_curvature
        sat = self.steering_saturation
        if math.isfinite(sat):  # the hinges give: the effective tan(lock) is sat * tanh(tan(lock) / sat)
            lock = sat * math.tanh(lock * self.wheelbase / sat) / self.wheelbase
        reach = self.steering_gain * lock / shrink
        return reach * tyre_response(reach * v * v / self.grip(v), self.tyre_shape)

    def cornering_speeds(self, curvature: np.ndarray) -> np.ndarray:
        """The fastest speed [m/s] at which the car still bends its path to ``|curvature|`` on full
        lock, at most the top speed; a crawl a little above the slowest speed where even at rest it
        cannot. The turning curvature only shrinks with speed, so it is inverted by bisection."""
        k = np.abs(np.asarray(curvature, dtype=float))
        top = self.top_speed
        if not math.isfinite(self.max_curvature) and self.grip_slip <= 0.0:  # the grip circle alone
            with np.errstate(divide="ignore"):
                return np.minimum(np.sqrt(self.lateral_accel / k), top)
        lo, hi = np.zeros_like(k), np.full_like(k, top)
        for _ in range(BISECTIONS):
            mid = 0.5 * (lo + hi)
            holds = self.turning_curvature(mid) >= k
            lo, hi = np.where(holds, mid, lo), np.where(holds, hi, mid)
        v = np.where(self.turning_curvature(np.full_like(k, top)) >= k, top, lo)
        crawl = CRAWL * self.min_command
        tightest = float(self.turning_curvature(np.array([0.0]))[0])
        return np.minimum(np.where(k > tightest, crawl, np.maximum(v, crawl)), top)

    def to_dict(self) -> dict[str, float | None]:
        """A JSON-friendly dict (an infinite limit becomes ``None``)."""
        return {k: (float(v) if math.isfinite(v) else None) for k, v in asdict(self).items()}


def grip_speeds(curvature: np.ndarray, limits: SpeedLimits) -> np.ndarray:
    """Speed cap [m/s] at each point from grip, the speed-dependent steering and the top speed."""
    # A bend tighter than the car turns at all is taken on its tightest turn, running a little wide.
    return np.minimum(limits.cornering_speeds(curvature), limits.top_speed)


def speed_profile(
    ds: np.ndarray,
    curvature: np.ndarray,
    closed: bool,
    limits: SpeedLimits,
    start_speed: float | None = None,
) -> np.ndarray:
    """The fastest speed [m/s] at each point of a path.

    :param ds: segment lengths [m]: ``m`` on loops (the last closes the loop), ``m - 1`` on open paths.
    :param curvature: ``(m,)`` curvature [1/m] at each point.
    :param closed: whether the path is a loop.
    :param limits: the car's limits.
    :param start_speed: speed at point 0 [m/s]: ``0.0`` for a standing start;
        ``None`` for a flying lap on loops (open paths then start from rest).
    :return: ``(m,)`` speeds.
    """
    cap = grip_speeds(curvature, limits)
    m = len(cap)
    if closed and start_speed is None:
        backward = _sweep_backward(ds, cap, curvature, closed=True, limits=limits)
        return _sweep_forward(ds, backward, curvature, closed=True, limits=limits)
    v0 = 0.0 if start_speed is None else start_speed
    if closed:  # standing start on a loop: the braking envelope still wraps round to the next lap
        envelope = _sweep_backward(ds, cap, curvature, closed=True, limits=limits)
    else:
        envelope = _sweep_backward(ds, cap, curvature, closed=False, limits=limits)
    envelope = envelope.copy()
    envelope[0] = min(envelope[0], v0)
    forward = _sweep_forward(ds, envelope, curvature, closed=False, limits=limits, count=m)
    return forward


def lap_time(ds: np.ndarray, speeds: np.ndarray, closed: bool) -> float:
    """Time [s] to drive the path at ``speeds`` with constant acceleration per segment."""
    nxt = np.roll(speeds, -1) if closed else speeds[1:]
    cur = speeds if closed else speeds[:-1]
    mean = 0.5 * (cur + nxt)
    if np.any(mean <= 0):
        raise ValueError("lap_time: the speed profile stops somewhere; the lap never ends.")
    return float(np.sum(ds[: len(mean)] / mean))


def _sweep_forward(
    ds: np.ndarray,
    cap: np.ndarray,
    curvature: np.ndarray,
    *,
    closed: bool,
    limits: SpeedLimits,
    count: int | None = None,
) -> np.ndarray:
    """Carry speeds forward at full throttle under ``cap`` (from its minimum on loops, else from 0);
    in a bend the throttle leaves the tyres the grip it needs (:meth:`SpeedLimits.accel_in_bend`)."""
    m = len(cap) if count is None else count
    v = cap.copy()
    start = int(np.argmin(cap)) if closed else 0
    steps = m if closed else m - 1
    for j in range(steps):
        i = (start + j) % m
        k = (i + 1) % m
        reach = _integrate(v[i], ds[i], _throttle(limits, max(abs(curvature[i]), abs(curvature[k]))))
        if reach < v[k]:
            v[k] = reach
    return v


def _throttle(limits: SpeedLimits, bend: float) -> Callable[[float], float]:
    """Full-throttle acceleration as a function of speed on a segment bending by ``bend`` [1/m]."""
    if limits.grip_slip <= 0.0:
        return limits.accel
    return lambda v: limits.accel_in_bend(v, bend)


def _brakes(limits: SpeedLimits, bend: float) -> Callable[[float], float]:
    """Full-braking deceleration as a function of speed on a segment bending by ``bend`` [1/m]."""
    if limits.grip_slip <= 0.0:
        return limits.brake
    return lambda v: limits.brake_in_bend(v, bend)


def _sweep_backward(
    ds: np.ndarray, cap: np.ndarray, curvature: np.ndarray, *, closed: bool, limits: SpeedLimits
) -> np.ndarray:
    """Carry speeds backward at full braking under ``cap`` (from its minimum on loops, else from the end);
    in a bend the brakes leave the tyres the grip it needs (:meth:`SpeedLimits.brake_in_bend`)."""
    m = len(cap)
    v = cap.copy()
    start = int(np.argmin(cap)) if closed else m - 1
    steps = m if closed else m - 1
    for j in range(steps):
        k = (start - j) % m
        i = (k - 1) % m
        reach = _integrate(v[k], ds[i], _brakes(limits, max(abs(curvature[i]), abs(curvature[k]))))
        if reach < v[i]:
            v[i] = reach
    return v


def _integrate(v: float, distance: float, accel: Callable[[float], float]) -> float:
    """Speed after ``distance`` [m] from ``v`` with acceleration ``accel(v)``: RK4 in ``u = v^2``."""
    u = v * v
    h = distance / RK_SUBSTEPS

    def du(u_: float) -> float:
        return 2.0 * accel(math.sqrt(max(u_, 0.0)))

    for _ in range(RK_SUBSTEPS):
        k1 = du(u)
        k2 = du(u + 0.5 * h * k1)
        k3 = du(u + 0.5 * h * k2)
        k4 = du(u + h * k3)
        u += h * (k1 + 2 * k2 + 2 * k3 + k4) / 6.0
    return math.sqrt(max(u, 0.0))
