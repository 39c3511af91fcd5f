"""Vehicle dynamics of a 1/18 DeepRacer car as DeepRacer's simulator drives it, stepped at ~15 Hz.

DeepRacer's simulated car is not an ideal bicycle (DEEPRACER.md section 4):
Gazebo drives all four wheels at ``speed / 0.035`` rad/s through weak PID
effort controllers (deepracer-simapp
``bundle/src/deepracer_simulation_environment/config/racecar_control_kinematics.yaml``, which
models of version 5 and later get, ``racecar_control.yaml`` older ones, with the same gains:
P 1.0 rear, 0.5 front, no I or D; ``bundle/markov/agent_ctrl/utils.py``
``get_wheel_radius`` 0.035 m) with no differential, on tyres of friction 0.5.
In its logs (``../shared/deepracer-logs/``) a held 30 deg command turns on
0.75-1.1 m at 1 m/s instead of the bicycle's 0.28 m, the car takes about a
second to reach 4 m/s, and commands act with a lag. drx reproduces that with a
cheap grey-box model whose constants are fitted to those logs
(:mod:`drx.sim.car_calibration`, written by ``tools/fit_car_model.py``; one
set per DeepRacer simulator version, as the two versions in the logs drive
differently, :meth:`CarParams.for_simulator`; the default is the newest):

* **command delay**: a command acts ``command_delay`` steps after it is given
  (the fraction of a step is honoured inside the step);
* **steering**: the steering angle follows the command through a first-order
  lag whose time constant grows with speed (``steering_time_constant +
  steering_time_constant_per_speed * v``); the path bends far less than an ideal
  bicycle's ``tan(delta) / wheelbase``, as the scrubbing four-wheel drive and
  the weak steering hinges let the car understeer (the logs show about a
  third of it), and less still the faster it goes:
  ``curvature = gain * tan(delta) / wheelbase / (1 + k1 v + k2 v^2)``;
* **tyres**: the lateral acceleration that curvature asks for, ``a = curvature
  v^2``, is delivered as ``a / (1 + (a / g)^n)^(1/n)`` with ``g`` the grip and ``n``
  ``tyre_shape`` (:func:`tyre_response`): linear while small, levelling off at
  grip (a tyre's lateral force grows with slip and levels off, as a brush or
  Pacejka curve does), as sharply as the fit finds (``n`` 2.5 is close to a
  ``tanh``, the curve drx used before; simapp 5's logs want a near-hard cap), and the
  car is ``sliding`` past the limit;
* **hinge give**: the effective ``tan(delta)`` saturates towards ``steering_saturation`` (a held 30 deg
  bends the path less, for its angle, than 5 deg does);
* **yaw lag**: a share ``yaw_lag_share`` of that bend builds up through a first-order lag whose time
  constant grows with speed (``yaw_time_constant + yaw_time_constant_per_speed * v``; the state
  ``CarState.curvature``), as a dynamic bicycle's yaw inertia and tyre slip make it: in simapp 5's
  logs a 30 deg command held at 2 m/s gets 2.1 m/s^2 from the tyres after 4 steps and 4.0 after 7.
  A full dynamic bicycle (deepracer-simapp ``bundle/urdf/deepracer/deepracer_single_cam.urdf``:
  chassis 5.0 kg, ``izz`` 0.0587 kg m^2; ``bundle/urdf/deepracer/racecar.gazebo``: wheels ``mu1`` =
  ``mu2`` = 0.5, contact ``kp`` 1e6, ``kd`` 1; steering hinges position-controlled, P 1.0, D 0.5 in
  ``racecar_control.yaml``) needs sub-steps at 15 Hz that the step budget does not allow; the lag
  is its cheap stand-in;
* **side slip**: the point of the body that moves along the heading (the
  *pivot*) sits ``pivot_offset`` ahead of the rear axle, not on it, so the rear
  swings out in turns as a sliding car's does;
* **speed**: the speed follows ``speed_gain * command + speed_offset`` through a lag whose
  time constant grows with speed (``speed_time_constant +
  speed_time_constant_per_speed * v``: the PID's effort fades as the wheel
  speed nears its target), bounded by ``max_acceleration`` and ``max_braking``.

The state is referenced at the rear-axle centre; DeepRacer's car origin is the
middle of the wheelbase (``origin_offset`` ahead of the rear axle) and the
reward ``params`` (x, y) is 0.14 m ahead of that origin
(deepracer-simapp ``bundle/markov/agent_ctrl/constants.py``
``RELATIVE_POSITION_OF_FRONT_OF_CAR = [0.14, 0, 0]``), i.e.
``reference_offset`` = 0.222 m ahead of the rear axle.

The step is scalar Python (a few microseconds): highway-env's
``Vehicle.step`` allocates NumPy arrays and clips through its road network on
every call, which costs more than drx's whole step budget, and has no lag,
slip or speed-dependent steering.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np

from drx.errors import DrxError
from drx.sim import car_calibration as cal

G = 9.81  # [m/s^2]
_FITTED = cal.SIMULATORS[cal.DEFAULT_SIMULATOR]


@dataclass(frozen=True)
class CarParams:
    """Every physical constant of the simulated car, with units and source.

    Geometry (DEEPRACER.md section 1, deepracer-simapp's racecar URDF):

    :param wheelbase: rear to front axle [m] (0.164).
    :param track_width: distance between left and right wheel centres [m] (0.162).
    :param origin_offset: the car's origin (middle of the wheelbase) ahead of the rear axle [m].
    :param reference_ahead: the ``params`` (x, y) point ahead of the origin [m] (0.14).
    :param length: body length, for collisions [m].
    :param width: body width, for collisions [m].
    :param rate_hz: control and camera rate [Hz] (15).
    :param max_speed: fastest command DeepRacer accepts [m/s] (4).
    :param max_steering: steering command limit [rad] (30 deg).

    Fitted to DeepRacer's logs by ``tools/fit_car_model.py`` (values in
    :mod:`drx.sim.car_calibration`, with the data and residuals of the fit; the defaults are the
    newest simulator's, :meth:`for_simulator` gives the others):

    :param command_delay: steps between a command and its first effect [steps].
    :param steering_time_constant: first-order lag of the steering angle at rest [s].
    :param steering_time_constant_per_speed: growth of the steering lag with speed [s per m/s] (the
        yaw response of a real car slows as it goes faster).
    :param steering_gain: the path curvature as a share of an ideal bicycle's at rest [-].
    :param steering_saturation: the effective ``tan(steering)`` saturates towards this [-]:
        ``steering_saturation * tanh(tan(delta) / steering_saturation)`` (the weak steering hinges give way
        at large angles: a held 30 deg turns the car at walking pace less than 5 deg scaled up would).
    :param steering_speed_k1: linear shrink of the effective steering with speed [s/m].
    :param steering_speed_k2: quadratic shrink of the effective steering with speed [s^2/m^2].
    :param lateral_accel_max: the lateral acceleration the tyres saturate towards at rest [m/s^2].
    :param grip_slip: the wheels' longitudinal slip at which the tyres' lateral limit has fallen to
        ``1/sqrt(2)`` of ``lateral_accel_max`` [-] (0: no fall; :meth:`grip`).
    :param tyre_shape: how sharply the delivered lateral acceleration levels off at grip [-]
        (:func:`tyre_response`: 1 gentle, 2.5 about a ``tanh``, large a hard cap).
    :param yaw_lag_share: the share of the path's bend that builds up through the yaw lag [-] (0: the
        path bends as the steering asks at once).
    :param yaw_time_constant: time constant of that build-up at rest [s].
    :param yaw_time_constant_per_speed: its growth with speed [s per m/s] (a heavier-handed yaw
        response the faster the car goes, as a dynamic bicycle's).
    :param pivot_offset: the body point moving along the heading, ahead of the rear axle [m].
    :param speed_gain: steady speed per commanded m/s [-] (with ``speed_offset``: the car runs at
        ``speed_gain * command + speed_offset``).
    :param speed_offset: steady speed above ``speed_gain`` times the command [m/s].
    :param speed_time_constant: speed lag at rest [s].
    :param speed_time_constant_per_speed: growth of the speed lag with speed [s per m/s].
    :param max_acceleration: largest forward acceleration [m/s^2].
    :param max_braking: largest deceleration [m/s^2].
    :param wheel_speed_limit: the fastest command the wheels follow [m/s] (held, not fitted). Simapp 5
        drives every wheel at ``speed / 0.035 m`` rad/s (``rollout_agent_ctrl._update_speed``) through
        velocity controllers (``racecar_control_kinematics.yaml``) whose joints carry ``velocity="100"``
        (``urdf/deepracer/deepracer_single_cam.urdf``), which gazebo_ros_control enforces as a
        saturation (``VelocityJointSaturationHandle`` in ``default_robot_hw_sim.cpp``): any command
        above 100 * 0.035 = 3.5 m/s turns the wheels as 3.5 does. Simapp 4's effort controllers do not
        saturate the velocity, so its car has none below ``max_speed``.

    Noise (``drx.sim.noise``):

    :param step_time: mean length of a step [s] (DeepRacer: 1/15 nominal, 0.0667 in the logs).
    :param step_time_jitter: standard deviation of a step's length [s] (from the distances the car covers
        in the logs: :func:`drx.calibration.step_jitter.step_length_jitter`).
    """

    wheelbase: float = 0.164  # [m]
    track_width: float = 0.162  # [m]
    origin_offset: float = 0.082  # [m]
    reference_ahead: float = 0.14  # [m]
    length: float = 0.30  # [m]
    width: float = 0.20  # [m]
    rate_hz: float = 15.0  # [Hz]
    max_speed: float = 4.0  # [m/s]
    max_steering: float = math.radians(30.0)  # [rad]
    command_delay: float = _FITTED["command_delay"]  # [steps]
    steering_time_constant: float = _FITTED["steering_time_constant"]  # [s]
    steering_time_constant_per_speed: float = _FITTED["steering_time_constant_per_speed"]  # [s per m/s]
    steering_gain: float = _FITTED["steering_gain"]  # [-]
    steering_saturation: float = _FITTED["steering_saturation"]  # [-]
    steering_speed_k1: float = _FITTED["steering_speed_k1"]  # [s/m]
    steering_speed_k2: float = _FITTED["steering_speed_k2"]  # [s^2/m^2]
    lateral_accel_max: float = _FITTED["lateral_accel_max"]  # [m/s^2]
    grip_slip: float = _FITTED["grip_slip"]  # [-]
    tyre_shape: float = _FITTED["tyre_shape"]  # [-]
    yaw_lag_share: float = _FITTED["yaw_lag_share"]  # [-]
    yaw_time_constant: float = _FITTED["yaw_time_constant"]  # [s]
    yaw_time_constant_per_speed: float = _FITTED["yaw_time_constant_per_speed"]  # [s per m/s]
    pivot_offset: float = _FITTED["pivot_offset"]  # [m]
    speed_gain: float = _FITTED["speed_gain"]  # [-]
    speed_offset: float = _FITTED["speed_offset"]  # [m/s]
    speed_time_constant: float = _FITTED["speed_time_constant"]  # [s]
    speed_time_constant_per_speed: float = _FITTED["speed_time_constant_per_speed"]  # [s per m/s]
    max_acceleration: float = _FITTED["max_acceleration"]  # [m/s^2]
    max_braking: float = _FITTED["max_braking"]  # [m/s^2]
    wheel_speed_limit: float = _FITTED["wheel_speed_limit"]  # [m/s]
    step_time: float = _FITTED["step_time"]  # [s]
    step_time_jitter: float = _FITTED["step_time_jitter"]  # [s]

    @property
    def dt(self) -> float:
        """Nominal seconds per step [s]."""
        return 1.0 / self.rate_hz

    @property
    def reference_offset(self) -> float:
        """The ``params`` (x, y) point ahead of the rear axle [m] (0.222)."""
        return self.origin_offset + self.reference_ahead

    @functools.cached_property
    def delay_split(self) -> tuple[int, float]:
        """``(n, f)``: over a step, the command given ``n + 1`` steps ago acts for the first ``f`` of it,
        the one given ``n`` steps ago for the rest."""
        n = int(math.floor(self.command_delay))
        return n, self.command_delay - n

    def grip(self, speed: float, command: float | None = None) -> float:
        """The lateral acceleration [m/s^2] the tyres saturate towards at ``speed`` [m/s] with the wheels
        driven at ``command`` [m/s] (default: the command that holds ``speed``).

        DeepRacer drives every wheel at ``command / wheel radius`` (deepracer-simapp
        ``agent_ctrl/utils.py``); when the car runs slower than its wheels (accelerating, or short of a
        high command), the slipping tyres spend their friction (0.5, ``racecar.gazebo``) pulling and
        have less left for turning: the friction circle, ``a_max / sqrt(1 + (slip / grip_slip)^2)``."""
        if command is None:
            command = self.holding_command(speed)
        return float(slip_grip(self.lateral_accel_max, self.grip_slip, speed, command))

    def holding_command(self, speed: float) -> float:
        """The speed command [m/s] the car settles at ``speed`` [m/s] under (the inverse of
        :meth:`steady_speed`)."""
        return max(speed - self.speed_offset, 0.0) / self.speed_gain

    def slowest_command(self, curvature: float, speed: float) -> float:
        """The lowest speed command [m/s] whose backward wheel slip still leaves the tyres the grip to
        hold ``curvature`` [1/m] at ``speed`` [m/s] (:func:`slip_command_floor`)."""
        return slip_command_floor(self.lateral_accel_max, self.grip_slip, curvature, speed)

    def fastest_command(self, curvature: float, speed: float) -> float:
        """The highest speed command [m/s] whose wheel slip still leaves the tyres the grip to hold
        ``curvature`` [1/m] at ``speed`` [m/s] (:func:`slip_command_limit`)."""
        return slip_command_limit(self.lateral_accel_max, self.grip_slip, curvature, speed)

    @functools.cached_property
    def command_ceiling(self) -> float:
        """The fastest speed command [m/s] that still makes a difference: ``max_speed`` or the wheels'
        ``wheel_speed_limit``, whichever is lower."""
        return min(self.max_speed, self.wheel_speed_limit)

    def steady_speed(self, command: float) -> float:
        """The speed [m/s] the car settles at when a speed command [m/s] is held."""
        command = min(command, self.command_ceiling)
        return self.speed_gain * command + self.speed_offset if command > 0.0 else 0.0

    def with_values(self, **values: float) -> CarParams:
        """A copy with some constants replaced (the fitting script and tests use it)."""
        return replace(self, **values)

    @classmethod
    def for_simulator(cls, version: str) -> CarParams:
        """The car as fitted to the logs of one DeepRacer simulator version (deepracer-simapp ``4``:
        the console in 2022; ``5``: deepracer-for-cloud in 2023, the default).

        :raises DrxError: for a version without a calibration.
        """
        values = cal.SIMULATORS.get(str(version))
        if values is None:
            known = ", ".join(sorted(cal.SIMULATORS))
            raise DrxError(f"DeepRacer simulator {version!r} has no calibration; use one of {known}.")
        return cls(**values)

    @classmethod
    def held_out(cls, version: str, log: str) -> CarParams | None:
        """Simulator ``version``'s car fitted the same way but without the shared log ``log``
        (:data:`drx.sim.car_calibration.HELD_OUT`), or ``None`` when the fit made none: how the car
        does on a log it was not fitted to."""
        values = cal.HELD_OUT.get(str(version), {}).get(log)
        return None if values is None else cls(**values)


class CarState:
    """The car's state.

    :param x: rear-axle x [m].
    :param y: rear-axle y [m].
    :param yaw: heading [rad], counter-clockwise from world x.
    :param speed: forward speed of the pivot point [m/s].
    :param steering: steering angle before its speed-dependent shrink [rad], + = left.
    :param commands: the last commands ``(speed [m/s], steering [rad])``, newest last, for the delay.
    :param curvature: the lagging part of the path's curvature [1/m] (see ``yaw_lag_share``); it
        settles at :func:`steady_curvature` while a command is held.
    """

    __slots__ = ("x", "y", "yaw", "speed", "steering", "sliding", "commands", "curvature")

    def __init__(
        self,
        x: float,
        y: float,
        yaw: float,
        speed: float = 0.0,
        steering: float = 0.0,
        commands: list[tuple[float, float]] | None = None,
        curvature: float = 0.0,
    ) -> None:
        self.x, self.y, self.yaw, self.speed, self.steering = x, y, yaw, speed, steering
        self.curvature = curvature
        self.sliding = False
        # The car moving at `speed` with its wheels at `steering` was commanded so: hold that.
        self.commands = commands if commands is not None else [(speed, steering)] * 3

    @classmethod
    def moving(cls, x: float, y: float, yaw: float, speed: float, steering: float, p: CarParams) -> CarState:
        """A car already moving at ``speed`` [m/s] with its wheels at ``steering`` [rad], commanded so
        for a while (its delayed commands hold that motion)."""
        command = max((speed - p.speed_offset) / p.speed_gain, 0.0) if speed > 0.0 else 0.0
        bend = steady_curvature(steering, speed, p)
        return cls(x, y, yaw, speed, steering, [(command, steering)] * 3, bend)

    def copy(self) -> CarState:
        """An independent copy."""
        return CarState(
            self.x, self.y, self.yaw, self.speed, self.steering, list(self.commands), self.curvature
        )  # fmt: skip


def step_car(
    state: CarState, speed_cmd: float, steering_cmd: float, p: CarParams, dt: float | None = None
) -> None:
    """Advance ``state`` in place by one step of ``dt`` seconds under a new command.

    :param state: the car, updated in place.
    :param speed_cmd: commanded speed [m/s].
    :param steering_cmd: commanded steering [rad], + = left.
    :param p: the car's constants.
    :param dt: the step's length [s]; default the nominal ``1 / rate_hz``.
    """
    if dt is None:
        dt = 1.0 / p.rate_hz
    lim = p.max_steering
    steering_cmd = lim if steering_cmd > lim else (-lim if steering_cmd < -lim else steering_cmd)
    top = p.command_ceiling
    speed_cmd = 0.0 if speed_cmd < 0.0 else (top if speed_cmd > top else speed_cmd)
    cmds = state.commands
    cmds.append((speed_cmd, steering_cmd))
    del cmds[0]
    n, f = p.delay_split
    new = cmds[-1 - n]
    old = cmds[-2 - n] if f > 0.0 else new
    delta0, v0 = state.steering, state.speed
    delta, v = delta0, v0
    for cmd, h in ((old, f * dt), (new, (1.0 - f) * dt)):
        if h <= 0.0:
            continue
        target_v = p.speed_gain * cmd[0] + p.speed_offset if cmd[0] > 0.0 else 0.0
        tau_s = p.steering_time_constant + p.steering_time_constant_per_speed * v
        delta = cmd[1] + (delta - cmd[1]) * math.exp(-h / tau_s)
        tau = p.speed_time_constant + p.speed_time_constant_per_speed * v
        dv = (target_v - v) * (1.0 - math.exp(-h / tau))
        up, down = p.max_acceleration * h, p.max_braking * h
        v += up if dv > up else (-down if dv < -down else dv)
    v_mid = 0.5 * (v0 + v)
    delta_mid = 0.5 * (delta0 + delta)
    sat = p.steering_saturation
    kappa = p.steering_gain * sat * math.tanh(math.tan(delta_mid) / sat) / (
        p.wheelbase * (1.0 + v_mid * (p.steering_speed_k1 + p.steering_speed_k2 * v_mid))
    )
    # Tyre saturation: the lateral acceleration the bicycle asks for, a = kappa v^2, is delivered as
    # a / (1 + (a / g)^n)^(1/n) (tyre_response): linear while small, never above the grip g,
    # which falls as the wheels, driven at the command's speed, slip (CarParams.grip; both inlined:
    # this is the simulator's hot path)
    grip = p.lateral_accel_max
    if p.grip_slip > 0.0:
        c = new[0]
        slip = (c - v_mid) / max(c, v_mid, 0.1) / p.grip_slip
        grip /= math.sqrt(1.0 + slip * slip)
    load = abs(kappa) * v_mid * v_mid / grip
    sliding = load > 1.0
    if load > 1e-9:
        shape = p.tyre_shape
        kappa /= (1.0 + load**shape) ** (1.0 / shape)
    share = p.yaw_lag_share
    if share > 0.0:
        # Yaw lag: a share of the bend builds up over tau (slower the faster the car goes); over the
        # step that part averages target + (start - target) * (1 - e) * tau / dt.
        tau_y = p.yaw_time_constant + p.yaw_time_constant_per_speed * v_mid
        e = math.exp(-dt / tau_y)
        k0 = state.curvature - kappa
        state.curvature = kappa + k0 * e
        kappa += share * k0 * (1.0 - e) * tau_y / dt
    else:
        state.curvature = kappa
    # The pivot moves along the arc; the rear axle follows the body's rotation around it.
    yaw0 = state.yaw
    dyaw = v_mid * kappa * dt
    heading = yaw0 + 0.5 * dyaw
    dist = v_mid * dt
    po = p.pivot_offset
    yaw1 = yaw0 + dyaw
    state.x += po * (math.cos(yaw0) - math.cos(yaw1)) + dist * math.cos(heading)
    state.y += po * (math.sin(yaw0) - math.sin(yaw1)) + dist * math.sin(heading)
    state.yaw = (yaw1 + math.pi) % (2.0 * math.pi) - math.pi
    state.speed = v
    state.steering = delta
    state.sliding = sliding


def tyre_response(load: Any, shape: float) -> Any:
    """The share of the lateral acceleration asked for that the tyres deliver, at ``load`` = asked /
    grip [-] (a float or an array): ``1 / (1 + |load|^shape)^(1/shape)`` (delivered ``a / (1 + (a /
    g)^n)^(1/n)``: linear while small, levelling off at grip, the sharper the larger ``shape``).
    :func:`step_car` inlines it."""
    return 1.0 / (1.0 + abs(load) ** shape) ** (1.0 / shape)


def tyre_demand(delivered: float, shape: float) -> float:
    """The load (asked / grip) at which the tyres deliver ``delivered``, a share of grip of magnitude
    below 1 (signed as it): the inverse of ``load * tyre_response(load, shape)``.

    :raises ValueError: when ``|delivered| >= 1`` (no load delivers grip or more).
    """
    share = abs(delivered)
    if share >= 1.0:
        raise ValueError(f"the tyres never deliver {delivered} of grip")
    return math.copysign(share / (1.0 - share**shape) ** (1.0 / shape), delivered)


def slip_grip(lateral_accel_max: float, grip_slip: float, speed: Any, command: Any) -> Any:
    """The tyres' lateral limit [m/s^2] when the wheels are driven at ``command`` [m/s] and the car runs
    at ``speed`` [m/s] (floats, or arrays for the batched step and the best-lap solver):
    ``lateral_accel_max / sqrt(1 + (slip / grip_slip)^2)`` with the slip ``(command - speed) /
    max(command, speed)`` (:meth:`CarParams.grip`; ``grip_slip`` 0: no fall). :func:`step_car`
    inlines it."""
    if grip_slip <= 0.0:
        return lateral_accel_max if np.ndim(speed) == 0 else np.full(np.shape(speed), lateral_accel_max)
    slip = (command - speed) / np.maximum(np.maximum(command, speed), 0.1)
    grip = lateral_accel_max / np.sqrt(1.0 + (slip / grip_slip) ** 2)
    return float(grip) if np.ndim(grip) == 0 else grip


def slip_command_limit(lateral_accel_max: float, grip_slip: float, curvature: float, speed: float) -> float:
    """The highest speed command [m/s] at which :func:`slip_grip` still covers the lateral acceleration
    ``curvature * speed^2`` (infinite when any command does; ``speed`` itself, no slip, when none does).
    Drivers cap their throttle with it in a bend, and the best-lap solver its acceleration."""
    need = abs(curvature) * speed * speed
    if grip_slip <= 0.0 or need <= 1e-9:
        return math.inf
    if need >= lateral_accel_max:
        return speed
    slip = grip_slip * math.sqrt((lateral_accel_max / need) ** 2 - 1.0)
    return speed / (1.0 - slip) if slip < 1.0 else math.inf


def slip_command_floor(lateral_accel_max: float, grip_slip: float, curvature: float, speed: float) -> float:
    """The lowest speed command [m/s] at which :func:`slip_grip` still covers the lateral acceleration
    ``curvature * speed^2``: braking by a command below the speed makes the wheels slip backwards and
    spends the friction the bend needs, as throttle does forwards (:func:`slip_command_limit`). 0 when
    any command does; ``speed`` itself, no slip, when none does."""
    need = abs(curvature) * speed * speed
    if grip_slip <= 0.0 or need <= 1e-9:
        return 0.0
    if need >= lateral_accel_max:
        return speed
    slip = grip_slip * math.sqrt((lateral_accel_max / need) ** 2 - 1.0)
    return speed * (1.0 - slip) if slip < 1.0 else 0.0


def steady_curvature(steering: float, speed: float, p: CarParams) -> float:
    """The path curvature [1/m] of a car holding ``steering`` [rad] at ``speed`` [m/s] once the steering
    has settled: the bicycle's, scaled by ``steering_gain`` and the speed shrink, then saturated by
    grip as :func:`step_car` does (its side slip aside)."""
    v = max(speed, 0.0)
    sat = p.steering_saturation
    kappa = p.steering_gain * sat * math.tanh(math.tan(steering) / sat) / (
        p.wheelbase * (1.0 + v * (p.steering_speed_k1 + p.steering_speed_k2 * v))
    )
    return float(kappa * tyre_response(kappa * v * v / p.grip(v), p.tyre_shape))


def steering_for_curvature(
    curvature: float, speed: float, p: CarParams, command: float | None = None
) -> float:
    """The steering command [rad] that bends the car's path to ``curvature`` [1/m] at ``speed`` [m/s]
    once the steering has settled: the inverse of :func:`steady_curvature` (drivers that steer by
    geometry use it; a bicycle's ``atan(L * curvature)`` asks for too little). Beyond grip it asks for
    the lock that reaches 99.9% of grip: more only slides. ``command`` is the speed command the wheels
    are driven at (default: the one that holds ``speed``; :meth:`CarParams.grip`)."""
    v = max(speed, 0.0)
    lateral = abs(curvature) * v * v / p.grip(v, command)
    if lateral > 1e-9:  # the lateral acceleration the tyres must be asked for (tyre_demand)
        curvature *= tyre_demand(min(lateral, 0.999), p.tyre_shape) / lateral
    shrink = 1.0 + v * (p.steering_speed_k1 + p.steering_speed_k2 * v)
    effective = curvature * p.wheelbase * shrink / p.steering_gain  # the effective tan(steering)
    sat = p.steering_saturation
    ratio = max(min(effective / sat, 0.999), -0.999)  # past the hinges' saturation: the lock that nears it
    return math.atan(sat * math.atanh(ratio))


def steady_state(speed_cmd: float, steering_cmd: float, p: CarParams, seconds: float = 3.0) -> CarState:
    """The car after holding one command for ``seconds`` from rest (for tools and tests)."""
    state = CarState(0.0, 0.0, 0.0)
    for _ in range(int(round(seconds * p.rate_hz))):
        step_car(state, speed_cmd, steering_cmd, p)
    return state


def wheel_positions(x: float, y: float, yaw: float, p: CarParams) -> tuple[tuple[float, float], ...]:
    """World positions of the four wheel contact points from the rear-axle pose.

    :return: ``((x, y), ...)`` for rear-left, rear-right, front-left, front-right [m].
    """
    c, s = math.cos(yaw), math.sin(yaw)
    hw = 0.5 * p.track_width
    lx, ly = -s * hw, c * hw  # unit left * half track
    fx, fy = x + c * p.wheelbase, y + s * p.wheelbase
    return ((x + lx, y + ly), (x - lx, y - ly), (fx + lx, fy + ly), (fx - lx, fy - ly))


def rear_axle_from_reference(x: float, y: float, yaw: float, p: CarParams) -> tuple[float, float]:
    """The rear-axle centre of a car whose ``params`` reference point is at (x, y) [m]."""
    return x - p.reference_offset * math.cos(yaw), y - p.reference_offset * math.sin(yaw)


def rear_axle_from_origin(x: float, y: float, yaw: float, p: CarParams) -> tuple[float, float]:
    """The rear-axle centre of a car whose origin (the middle of the wheelbase) is at (x, y) [m]."""
    return x - p.origin_offset * math.cos(yaw), y - p.origin_offset * math.sin(yaw)


def reference_point(state: CarState, p: CarParams) -> tuple[float, float]:
    """The ``params`` (x, y): ``reference_offset`` ahead of the rear axle [m]."""
    return (
        state.x + p.reference_offset * math.cos(state.yaw),
        state.y + p.reference_offset * math.sin(state.yaw),
    )


def as_dict(p: CarParams) -> dict[str, Any]:
    """The constants as a plain dict (for reports)."""
    return {f.name: getattr(p, f.name) for f in fields(p)}
