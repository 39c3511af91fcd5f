"""Open-loop replay of DeepRacer's logs through drx's car: how far apart do they end?

For every window of ``horizon`` steps inside an episode of a DeepRacer trace
(:mod:`drx.calibration.logs`), drx's car starts at the logged pose, moving
at the logged speed and bending as the log did the step before
(:func:`logged_motion`), with its steering where the earlier commands left it,
and is driven by the logged commands, each step as long as the episode's mean step (below). The
reference point and heading it reaches are compared with the log's. This is
how ``drx sim replay`` checks drx against a user's own DeepRacer runs, how
``benchmarks/replay_fidelity.py`` measures the fit, and what
``tools/fit_car_model.py`` minimises.

A window is used when every row in it is ``in_progress`` (no reset, pause or
start inside it) and its logged step times are sane (0.02-0.2 s). The car
drives each step for the episode's mean step time, not the logged one: the
logged clock jitters independently of the car
(:mod:`drx.calibration.logs`); driven by it, the replay's errors grew (simapp 5's logs: 14.3 cm
median and 34.9 cm p90 with the mean, 15.5 and 37.2 cm with the logged times, before refitting). The
start speed is the car origin's displacement over the two steps before the window, divided by
their time, its bend the origin's turn over the step before; the steering state
comes from driving the episode's earlier commands through the model's steering lag.

The baseline ``extrapolation`` drives the last logged motion on (constant speed
and yaw rate), the yardstick a car model must beat.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from drx.calibration.logs import LoggedEpisode
from drx.sim.dynamics import CarParams, CarState, rear_axle_from_reference, step_car

DEFAULT_HORIZON = 15  # [steps] one second
SPEED_BANDS = ((0.0, 1.5), (1.5, 2.5), (2.5, 4.5))  # [m/s] of the window's mean commanded speed
STEERING_BANDS = ((0.0, 10.0), (10.0, 20.0), (20.0, 30.1))  # [deg] of the window's mean |steering|
FAST_COMMAND = 2.5  # [m/s] the "fast" band: mean command >= this
HARD_STEERING = 20.0  # [deg] the "hard steering" band: mean |command| >= this


@dataclass(frozen=True)
class Window:
    """A stretch of ``horizon`` logged steps to replay: ``episode`` index into the list, ``start`` row."""

    episode: int
    start: int


@dataclass
class ReplayResult:
    """Errors of one replay, one entry per window.

    :param horizon: steps replayed per window.
    :param position_error: [m] distance between drx's and the log's reference point after the horizon.
    :param heading_error: [deg] absolute heading difference after the horizon.
    :param mean_speed_command: [m/s] the window's mean commanded speed.
    :param mean_abs_steering: [deg] the window's mean absolute commanded steering.
    :param baseline_error: [m] the same distance for constant-motion extrapolation.
    :param errors_by_step: ``(windows, horizon)`` [m] the position error after each step.
    :param paths: for a few windows, ``(logged (h+1, 2), simulated (h+1, 2))`` reference-point paths.
    """

    horizon: int
    position_error: np.ndarray
    heading_error: np.ndarray
    mean_speed_command: np.ndarray
    mean_abs_steering: np.ndarray
    baseline_error: np.ndarray
    errors_by_step: np.ndarray | None = None
    paths: list[tuple[np.ndarray, np.ndarray]] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.position_error)

    def subset(self, mask: np.ndarray) -> ReplayResult:
        """The windows where ``mask`` holds (paths dropped)."""
        return ReplayResult(
            self.horizon, self.position_error[mask], self.heading_error[mask], self.mean_speed_command[mask],
            self.mean_abs_steering[mask], self.baseline_error[mask],
        )  # fmt: skip

    def summary(self) -> dict[str, Any]:
        """Medians and 90th percentiles overall, per speed band and per steering band (JSON-friendly)."""
        out: dict[str, Any] = {"horizon_steps": self.horizon, "overall": _stats(self)}
        out["fast_commands"] = _stats(self.subset(self.mean_speed_command >= FAST_COMMAND))
        out["hard_steering"] = _stats(self.subset(self.mean_abs_steering >= HARD_STEERING))
        speed = self.mean_speed_command
        out["by_speed"] = {
            f"{lo:g}-{hi:g} m/s": _stats(self.subset((speed >= lo) & (speed < hi))) for lo, hi in SPEED_BANDS
        }
        out["by_steering"] = {
            f"{lo:g}-{min(hi, 30):g} deg": _stats(
                self.subset((self.mean_abs_steering >= lo) & (self.mean_abs_steering < hi))
            )
            for lo, hi in STEERING_BANDS
        }
        return out


def _stats(r: ReplayResult) -> dict[str, Any]:
    if len(r) == 0:
        return {"windows": 0}
    return {
        "windows": len(r),
        "position_median_cm": round(100.0 * float(np.median(r.position_error)), 1),
        "position_p90_cm": round(100.0 * float(np.percentile(r.position_error, 90)), 1),
        "heading_median_deg": round(float(np.median(r.heading_error)), 2),
        "heading_p90_deg": round(float(np.percentile(r.heading_error, 90)), 2),
        "extrapolation_median_cm": round(100.0 * float(np.median(r.baseline_error)), 1),
    }


def windows(
    episodes: Sequence[LoggedEpisode], horizon: int = DEFAULT_HORIZON, stride: int = 1
) -> list[Window]:
    """Every replayable window of ``horizon`` steps (see the module docstring), every ``stride``-th."""
    out = []
    for i, ep in enumerate(episodes):
        ok = ep.driving
        good_dt = ep.sane_steps
        n = len(ep)
        count = 0
        for k in range(2, n - horizon):
            # rows k-1 .. k+horizon in progress; the steps k-1 -> k .. k+h-1 -> k+h of sane length
            if ok[k - 1 : k + horizon + 1].all() and good_dt[k - 1 : k + horizon].all():
                if count % stride == 0:
                    out.append(Window(i, k))
                count += 1
    return out


History = list[tuple[float, list[tuple[float, float]], float]]  # steering, command queue, lagging bend


def command_history(ep: LoggedEpisode, car: CarParams) -> History:
    """Per row k: drx's steering state, command queue and lagging curvature after the logged commands
    of rows 0..k-1."""
    state = CarState(0.0, 0.0, 0.0)
    history = [(state.steering, list(state.commands), state.curvature)]
    steer = np.radians(ep.steer)
    dts = ep.step_times
    for j in range(len(ep) - 1):
        step_car(state, float(ep.throttle[j]), float(steer[j]), car, float(dts[j]))
        history.append((state.steering, list(state.commands), state.curvature))
    return history


def logged_motion(ep: LoggedEpisode, k: int, ahead: float) -> tuple[float, float | None]:
    """The car's speed [m/s] and path curvature [1/m] at row ``k`` of ``ep``, as the log shows them.

    The speed is the origin's (``ahead`` behind the reference point) displacement over the two steps
    before ``k`` divided by their time (over the one step before when row ``k - 2`` is not part of
    the same drive): the logged positions are noisy at the scale of one step, and the two-step
    estimate cut the replay's median error after 15 steps by 1.6 cm (18.2 -> 16.6 cm on simapp 5's
    logs). The curvature is the origin's turn over the step before, divided by its path (``None``
    when the car hardly moved): the bend the car is carrying into the window.
    """
    ox = [ep.x[j] - ahead * math.cos(ep.yaw[j]) for j in (k - 2, k - 1, k)] if k >= 2 else None
    if ox is None:
        return 0.0, None
    oy = [ep.y[j] - ahead * math.sin(ep.yaw[j]) for j in (k - 2, k - 1, k)]
    step = math.hypot(ox[2] - ox[1], oy[2] - oy[1])
    times = ep.step_times
    if ep.driving[k - 2] and ep.sane_steps[k - 2]:
        speed = math.hypot(ox[2] - ox[0], oy[2] - oy[0]) / float(times[k - 2] + times[k - 1])
    else:
        speed = step / float(times[k - 1])
    curvature = _wrap(float(ep.yaw[k] - ep.yaw[k - 1])) / step if step > 1e-3 else None
    return speed, curvature


def start_state(ep: LoggedEpisode, k: int, car: CarParams, history: list) -> CarState:
    """drx's car at row ``k`` of ``ep``: the logged pose, speed and bend (:func:`logged_motion`), the
    steering state and command queue from ``history`` (:func:`command_history`; the lagging curvature
    too when the log shows none)."""
    yaw = float(ep.yaw[k])
    speed, curvature = logged_motion(ep, k, car.reference_ahead)
    rx, ry = rear_axle_from_reference(float(ep.x[k]), float(ep.y[k]), yaw, car)
    steering, commands, history_curvature = history[k]
    bend = history_curvature if curvature is None else curvature
    return CarState(rx, ry, yaw, speed, steering, list(commands), bend)


def drive(ep: LoggedEpisode, k: int, steps: int, car: CarParams, history: list) -> np.ndarray:
    """Drive drx's car from row ``k`` with the logged commands for ``steps`` steps (each as long as
    :attr:`LoggedEpisode.step_times` says: the episode's mean step).

    :return: ``(steps + 1, 3)``: the reference point ``x, y`` [m] and yaw [rad] at rows ``k .. k + steps``.
    """
    state = start_state(ep, k, car, history)
    ref = car.reference_offset
    out = [(float(ep.x[k]), float(ep.y[k]), float(ep.yaw[k]))]
    throttle = ep.throttle[k : k + steps].tolist()
    steer = np.radians(ep.steer[k : k + steps]).tolist()
    dts = ep.step_times[k : k + steps].tolist()
    for i in range(steps):
        step_car(state, throttle[i], steer[i], car, dts[i])
        out.append((state.x + ref * math.cos(state.yaw), state.y + ref * math.sin(state.yaw), state.yaw))
    return np.array(out)


def replay(
    episodes: Sequence[LoggedEpisode],
    car: CarParams | None = None,
    horizon: int = DEFAULT_HORIZON,
    stride: int = 1,
    chosen: Iterable[Window] | None = None,
    keep_paths: int = 0,
) -> ReplayResult:
    """Replay ``episodes`` open-loop through drx's car (see the module docstring).

    :param episodes: logged episodes.
    :param car: the car model (default :class:`CarParams`, the calibrated car).
    :param horizon: steps per window.
    :param stride: use every ``stride``-th window (faster, for fitting).
    :param chosen: replay these windows instead of all of them.
    :param keep_paths: keep the reference-point paths of this many windows, spread over the data.
    """
    p = car or CarParams()
    wins = list(chosen) if chosen is not None else windows(episodes, horizon, stride)
    n = len(wins)
    pos, head, vcmd, scmd, base = (np.empty(n) for _ in range(5))
    by_step = np.empty((n, horizon))
    keep = set(np.linspace(0, n - 1, keep_paths).astype(int).tolist()) if keep_paths and n else set()
    paths: list[tuple[np.ndarray, np.ndarray]] = []
    cached: tuple[int, list] = (-1, [])
    for w_i, w in enumerate(wins):
        ep = episodes[w.episode]
        if cached[0] != w.episode:  # windows come grouped by episode
            cached = (w.episode, command_history(ep, p))
        k, end = w.start, w.start + horizon
        sim = drive(ep, k, horizon, p, cached[1])
        dist = np.hypot(sim[1:, 0] - ep.x[k + 1 : end + 1], sim[1:, 1] - ep.y[k + 1 : end + 1])
        by_step[w_i] = dist
        pos[w_i] = dist[-1]
        head[w_i] = abs(math.degrees(_wrap(float(sim[-1, 2] - ep.yaw[end]))))
        vcmd[w_i] = float(np.mean(ep.throttle[k:end]))
        scmd[w_i] = float(np.mean(np.abs(ep.steer[k:end])))
        base[w_i] = _extrapolation_error(ep, k, horizon)
        if w_i in keep:
            logged = np.column_stack([ep.x[k : end + 1], ep.y[k : end + 1]])
            paths.append((logged, sim[:, :2].copy()))
    return ReplayResult(horizon, pos, head, vcmd, scmd, base, by_step, paths)


def _wrap(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def _extrapolation_error(ep: LoggedEpisode, k: int, horizon: int) -> float:
    """Constant speed and yaw rate of the step before ``k``, carried on for the horizon's time."""
    dt0 = float(ep.step_times[k - 1])
    vx, vy = (ep.x[k] - ep.x[k - 1]) / dt0, (ep.y[k] - ep.y[k - 1]) / dt0
    speed = math.hypot(vx, vy)
    rate = _wrap(float(ep.yaw[k] - ep.yaw[k - 1])) / dt0
    heading = math.atan2(vy, vx)
    t = float(ep.step_times[k : k + horizon].sum())
    if abs(rate) < 1e-6:
        ex, ey = ep.x[k] + speed * t * math.cos(heading), ep.y[k] + speed * t * math.sin(heading)
    else:
        r = speed / rate
        ex = ep.x[k] + r * (math.sin(heading + rate * t) - math.sin(heading))
        ey = ep.y[k] - r * (math.cos(heading + rate * t) - math.cos(heading))
    return math.hypot(ex - ep.x[k + horizon], ey - ep.y[k + horizon])


@dataclass(frozen=True)
class HeldCommand:
    """What the car does after holding one command, in the log and in drx (medians).

    :param steering: the held steering command [deg] (NaN for a speed command held whatever the steering
        did, whose radii then mean nothing: :func:`held_commands` ``same_steering``).
    :param speed: the held speed command [m/s].
    :param samples: logged steps measured.
    :param log_radius: [m] turning radius of the car's origin in the log (inf when straight).
    :param drx_radius: [m] the same for drx's car, started where the log was ``hold`` steps earlier.
    :param log_speed: [m/s] speed of the reference point in the log.
    :param drx_speed: [m/s] the same for drx.
    """

    steering: float
    speed: float
    samples: int
    log_radius: float
    drx_radius: float
    log_speed: float
    drx_speed: float


def held_commands(
    episodes: Sequence[LoggedEpisode],
    car: CarParams | None = None,
    hold: int = 7,
    min_samples: int = 10,
    same_steering: bool = True,
) -> list[HeldCommand]:
    """Turning radius and speed after a command was held for ``hold`` steps, logged against drx.

    For each logged step ``k -> k+1`` whose command equals the ``hold - 1`` before it (all rows in
    progress), drx's car starts at row ``k - hold + 1`` as in :func:`replay` and drives the same
    commands; both cars' origin curvature and reference-point speed over ``k -> k+1`` are compared.
    With ``same_steering`` off only the speed command need be held (the groups' ``steering`` is NaN):
    for the speed a command settles at, whatever the steering did.
    """
    p = car or CarParams()
    ahead = p.reference_ahead
    h = hold - 1
    groups: dict[tuple[float, float], list[tuple[float, float, float, float]]] = {}
    for ep in episodes:
        ok = ep.driving
        dt = ep.step_times
        history: list | None = None
        for k in range(h + 1, len(ep) - 1):
            if not (ok[k - h - 1 : k + 2].all() and ep.sane_steps[k - h - 1 : k + 1].all()):
                continue
            if (same_steering and np.ptp(ep.steer[k - h : k + 1])) or np.ptp(ep.throttle[k - h : k + 1]):
                continue
            if history is None:
                history = command_history(ep, p)
            sim = drive(ep, k - h, h + 1, p, history)
            logged = np.column_stack([ep.x[k : k + 2], ep.y[k : k + 2], ep.yaw[k : k + 2]])
            kl, vl = _curvature_speed(logged, ahead, float(dt[k]))
            ks, vs = _curvature_speed(sim[-2:], ahead, float(dt[k]))
            # without the steering held, one group per speed command (its steering reported as NaN)
            steering = float(ep.steer[k]) if same_steering else 0.0
            groups.setdefault((steering, float(ep.throttle[k])), []).append((kl, ks, vl, vs))
    out = []
    for (steer, speed), rows in sorted(groups.items()):
        if len(rows) < min_samples:
            continue
        a = np.asarray(rows)
        kl, ks, vl, vs = (float(np.median(a[:, i])) for i in range(4))
        steering = steer if same_steering else math.nan
        out.append(HeldCommand(steering, speed, len(rows), _radius(kl), _radius(ks), vl, vs))
    return out


def _curvature_speed(poses: np.ndarray, ahead: float, dt: float) -> tuple[float, float]:
    """Curvature of the origin's path [1/m] and the reference point's speed [m/s] between two poses."""
    ox = poses[:, 0] - ahead * np.cos(poses[:, 2])
    oy = poses[:, 1] - ahead * np.sin(poses[:, 2])
    ds = math.hypot(ox[1] - ox[0], oy[1] - oy[0])
    dyaw = _wrap(float(poses[1, 2] - poses[0, 2]))
    return dyaw / max(ds, 1e-4), math.hypot(poses[1, 0] - poses[0, 0], poses[1, 1] - poses[0, 1]) / dt


def _radius(curvature: float) -> float:
    return math.inf if abs(curvature) < 1e-6 else 1.0 / abs(curvature)


@dataclass(frozen=True)
class Braking:
    """How fast the car slows when a fast command drops to a slow one, in the log and in drx (medians).

    :param samples: braking stretches measured.
    :param log_deceleration: [m/s^2] the reference point's deceleration in the log.
    :param drx_deceleration: [m/s^2] the same for drx's car, started where the log was.
    """

    samples: int
    log_deceleration: float
    drx_deceleration: float


def hard_braking(
    episodes: Sequence[LoggedEpisode],
    car: CarParams | None = None,
    fast: float = 3.5,
    slow: float = 1.0,
    steps: int = 8,
    min_speed: float = 2.5,
) -> Braking | None:
    """The deceleration after a speed command of at least ``fast`` m/s drops to at most ``slow`` and
    stays there for ``steps`` steps, with the car above ``min_speed`` m/s (all rows in progress):
    the reference point's speed over the first of those steps less that over the last, per second
    between them, logged against drx's car started at the drop as :func:`replay` starts it. DeepRacer's
    wheels, velocity-driven on tyres of friction 0.5, cannot slow the car faster than the tyres grip
    (in simapp 5's logs about 4 m/s^2, the same from 3.5 m/s down to 1.5 m/s: a cap, not a lag);
    ``None`` when the logs hold no such stretch."""
    p = car or CarParams()
    log_rate, drx_rate = [], []
    for ep in episodes:
        history: list | None = None
        for k in range(2, len(ep) - steps - 1):
            if ep.throttle[k - 1] < fast or np.max(ep.throttle[k : k + steps]) > slow:
                continue
            if not (ep.driving[k - 2 : k + steps + 1].all() and ep.sane_steps[k - 2 : k + steps].all()):
                continue
            dt = ep.step_times
            if math.hypot(ep.x[k] - ep.x[k - 1], ep.y[k] - ep.y[k - 1]) / dt[k - 1] < min_speed:
                continue
            if history is None:
                history = command_history(ep, p)
            sim = drive(ep, k, steps, p, history)
            span = float(np.sum(dt[k + 1 : k + steps]))  # between the middles of the first and last step
            logged = np.hypot(np.diff(ep.x[k : k + steps + 1]), np.diff(ep.y[k : k + steps + 1]))
            driven = np.hypot(np.diff(sim[:, 0]), np.diff(sim[:, 1]))
            log_rate.append((logged[0] / dt[k] - logged[-1] / dt[k + steps - 1]) / span)
            drx_rate.append((driven[0] / dt[k] - driven[-1] / dt[k + steps - 1]) / span)
    if not log_rate:
        return None
    return Braking(len(log_rate), float(np.median(log_rate)), float(np.median(drx_rate)))
