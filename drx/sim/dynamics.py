"""Vehicle dynamics of a 1/18 DeepRacer car, stepped at 15 Hz.

The model is a grip-limited kinematic bicycle referenced at the rear axle:

* the commanded speed is reached through a first-order lag (time constant
  ``speed_time_constant``) with acceleration/braking limits;
* the front wheels follow the commanded steering through a rate-limited servo;
* the path curvature the wheels ask for, ``tan(delta) / wheelbase``, is capped by
  tyre grip: lateral acceleration cannot exceed ``grip * g``. A car that takes a
  tight corner too fast saturates its tyres, slides wide of the steered arc and
  leaves the road; slowly it follows the arc the wheels point to.

Conventions (x forward, yaw counter-clockwise from the world x axis, positive
steering turns left) follow highway-env's ``Vehicle`` kinematic bicycle. The
step itself is drx's own scalar code: highway-env's ``Vehicle.step`` allocates
NumPy arrays and clips through its road network on every call, which costs more
than drx's whole step budget (200 µs), and it has no servo, lag or grip limit.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

G = 9.81  # [m/s^2]


@dataclass(frozen=True)
class CarParams:
    """Every physical constant of the simulated car, with units.

    :param wheelbase: rear to front axle [m] (DeepRacer: 0.164).
    :param track_width: distance between left and right wheel centres [m] (DeepRacer: 0.162).
    :param reference_offset: the ``params`` (x, y) point ahead of the rear axle [m] (DeepRacer: 0.14).
    :param camera_offset: the camera ahead of the rear axle [m] (DeepRacer: 0.145).
    :param length: body length, for collisions [m].
    :param width: body width, for collisions [m].
    :param rate_hz: control and camera rate [Hz] (DeepRacer: 15).
    :param speed_time_constant: first-order lag from commanded to actual speed [s].
    :param max_acceleration: largest forward acceleration of the motor [m/s^2].
    :param max_braking: largest deceleration [m/s^2].
    :param max_speed: fastest the motor can drive [m/s]; commands above it are clipped.
    :param steering_rate: servo slew rate [rad/s].
    :param max_steering: mechanical steering limit [rad] (30 deg).
    :param grip: tyre friction coefficient; lateral acceleration is capped at ``grip * g``.
    """

    wheelbase: float = 0.164  # [m]
    track_width: float = 0.162  # [m]
    reference_offset: float = 0.14  # [m]
    camera_offset: float = 0.145  # [m]
    length: float = 0.30  # [m]
    width: float = 0.20  # [m]
    rate_hz: float = 15.0  # [Hz]
    speed_time_constant: float = 0.2  # [s]
    max_acceleration: float = 6.0  # [m/s^2]
    max_braking: float = 8.0  # [m/s^2]
    max_speed: float = 4.0  # [m/s]
    steering_rate: float = 5.0  # [rad/s], 60 deg sweep in ~0.2 s
    max_steering: float = math.radians(30.0)  # [rad]
    grip: float = 0.9  # [-]

    @property
    def dt(self) -> float:
        """Seconds per step [s]."""
        return 1.0 / self.rate_hz

    @functools.cached_property
    def step_constants(self) -> tuple[float, ...]:
        """Per-step constants of :func:`step_car`, computed once per car."""
        dt = 1.0 / self.rate_hz
        return (
            dt,
            1.0 - math.exp(-dt / self.speed_time_constant),  # lag factor per step
            self.steering_rate * dt,  # largest servo move per step [rad]
            self.max_acceleration * dt,  # [m/s per step]
            self.max_braking * dt,  # [m/s per step]
            self.grip * G,  # largest lateral acceleration [m/s^2]
        )


class CarState:
    """The car's state: rear-axle centre, yaw, speed and actual steering.

    :param x: rear-axle x [m].
    :param y: rear-axle y [m].
    :param yaw: heading [rad], counter-clockwise from world x.
    :param speed: forward speed [m/s].
    :param steering: actual front-wheel angle [rad], + = left.
    """

    __slots__ = ("x", "y", "yaw", "speed", "steering", "sliding")

    def __init__(self, x: float, y: float, yaw: float, speed: float = 0.0, steering: float = 0.0) -> None:
        self.x, self.y, self.yaw, self.speed, self.steering = x, y, yaw, speed, steering
        self.sliding = False

    def copy(self) -> CarState:
        """An independent copy."""
        return CarState(self.x, self.y, self.yaw, self.speed, self.steering)


def step_car(state: CarState, speed_cmd: float, steering_cmd: float, p: CarParams) -> None:
    """Advance ``state`` in place by one control period.

    :param state: the car, updated in place.
    :param speed_cmd: commanded speed [m/s].
    :param steering_cmd: commanded steering [rad], + = left.
    :param p: the car's constants.
    """
    dt, lag, max_move, max_up, max_down, a_lat = p.step_constants
    # Servo: move towards the command at most steering_rate * dt; use the mid-step angle.
    lim = p.max_steering
    target = lim if steering_cmd > lim else (-lim if steering_cmd < -lim else steering_cmd)
    delta_old = state.steering
    move = target - delta_old
    move = max_move if move > max_move else (-max_move if move < -max_move else move)
    delta = delta_old + move
    delta_mid = delta_old + 0.5 * move
    # Motor: first-order lag to the command, bounded by acceleration and braking.
    v_old = state.speed
    cmd = min(max(speed_cmd, 0.0), p.max_speed)
    dv = (cmd - v_old) * lag
    dv = min(dv, max_up) if dv > 0 else max(dv, -max_down)
    v = v_old + dv
    v_mid = 0.5 * (v_old + v)
    # Grip: curvature capped so that v^2 * kappa <= grip * g.
    kappa = math.tan(delta_mid) / p.wheelbase
    sliding = False
    if v_mid > 1e-6:
        k_max = a_lat / (v_mid * v_mid)
        if kappa > k_max:
            kappa, sliding = k_max, True
        elif kappa < -k_max:
            kappa, sliding = -k_max, True
    dyaw = v_mid * kappa * dt
    heading = state.yaw + 0.5 * dyaw  # midpoint rule along the arc
    dist = v_mid * dt
    state.x += dist * math.cos(heading)
    state.y += dist * math.sin(heading)
    state.yaw = (state.yaw + dyaw + math.pi) % (2.0 * math.pi) - math.pi
    state.speed = v
    state.steering = delta
    state.sliding = sliding


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


def reference_point(state: CarState, p: CarParams) -> tuple[float, float]:
    """The ``params`` (x, y): ``reference_offset`` ahead of the rear axle [m]."""
    return (
        state.x + p.reference_offset * math.cos(state.yaw),
        state.y + p.reference_offset * math.sin(state.yaw),
    )
