"""Scripted drivers: policies that steer by geometry instead of a trained network.

They make the time-trial rules testable without training, and show how close
a driver that knows the track gets to the theoretical best lap. A scripted
driver ignores its observation and reads the car's pose from the env (a
trained policy only ever sees the camera).

:class:`PathFollower` is a pure-pursuit controller (Coulter, 1992): it aims
at the point of its path ``lookahead`` metres ahead of the car's rear axle
and steers along the circle through it, curvature ``2 sin(alpha) / d``. The
steering that bends the car that much comes from the car model
(:func:`drx.sim.dynamics.steering_for_curvature`): DeepRacer's car needs
more than a bicycle's ``atan(L * curvature)``, the more so the faster it goes.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from drx.sim.dynamics import CarParams, steering_for_curvature
from drx.vehicle import Vehicle


class PathFollower:
    """A pure-pursuit driver along a path at given speeds.

    :param env: the ``drx/DeepRacer-v0`` env it drives (its car state is read each step).
    :param path: ``(m, 2)`` points [m] in driving order (a loop without closing duplicate, or open).
    :param speeds: ``(m,)`` target speed [m/s] at each point, or one speed for all.
    :param closed: whether the path is a loop.
    :param lookahead: [m] distance to the aim point (more = smoother, less = tighter).
    :param lookahead_time: [s] aim at least this many seconds of travel ahead (faster: further).
    :param anticipate: steer from the pose the car will have when the command takes hold (its
        delay and yaw lag, :func:`PathFollower._anticipated_pose`) rather than from where it is.
    """

    def __init__(
        self,
        env: Any,
        path: np.ndarray,
        speeds: np.ndarray | float,
        closed: bool = True,
        lookahead: float = 0.35,
        anticipate: bool = True,
        lookahead_time: float = 0.0,
    ) -> None:
        self.env = getattr(env, "unwrapped", env)
        self.anticipate = anticipate
        self.lookahead_time = lookahead_time
        self.path = np.asarray(path, dtype=float)
        self.speeds = np.broadcast_to(np.asarray(speeds, dtype=float), (len(self.path),)).copy()
        self.closed = closed
        self.lookahead = lookahead
        self.vehicle: Vehicle = self.env.vehicle
        self.car: CarParams = self.env.car
        self._index = 0
        self._choose = ActionChooser(self.vehicle)

    def command(self) -> tuple[float, float]:
        """The (steering [deg], speed [m/s]) the driver wants now."""
        st = self.env.car_state
        m = len(self.path)
        # nearest path point, searched in a window ahead of the last one (global on the first call)
        if self._index == 0:
            d2 = np.sum((self.path - (st.x, st.y)) ** 2, axis=1)
            self._index = int(np.argmin(d2))
        else:
            window = (
                (self._index + np.arange(-5, 40)) % m
                if self.closed
                else np.clip(self._index + np.arange(-5, 40), 0, m - 1)
            )
            d2 = np.sum((self.path[window] - (st.x, st.y)) ** 2, axis=1)
            self._index = int(window[int(np.argmin(d2))])
        x, y, yaw = self._anticipated_pose() if self.anticipate else (st.x, st.y, st.yaw)
        reach = max(self.lookahead, self.lookahead_time * st.speed)
        j = self._index
        for _ in range(m):
            nxt = (j + 1) % m if self.closed else min(j + 1, m - 1)
            if nxt == j or math.hypot(self.path[j, 0] - x, self.path[j, 1] - y) >= reach:
                break
            j = nxt
        tx, ty = self.path[j]
        alpha = math.atan2(ty - y, tx - x) - yaw
        alpha = math.atan2(math.sin(alpha), math.cos(alpha))
        dist = max(math.hypot(tx - x, ty - y), 1e-6)
        # the motor lags: ask early for the speed a few points ahead, the lowest of them when braking;
        # where the speeds rise, full throttle (the speed profile's own acceleration: asking only for
        # the next points' speeds, the lagging motor never reaches them)
        ahead = self._index + np.arange(0, 6)
        ahead = ahead % m if self.closed else np.clip(ahead, 0, m - 1)
        wanted = self.speeds[ahead]
        if np.min(wanted) < wanted[0]:
            speed = self.car.holding_command(float(np.min(wanted)))
        elif wanted[-1] > wanted[0] + 1e-6:
            speed = float(self.vehicle.max_speed)
        else:
            speed = self.car.holding_command(float(wanted[-1]))
        curvature = 2.0 * math.sin(alpha) / dist
        # in a bend, no more throttle than leaves the slipping wheels the grip to hold it
        speed = min(speed, self.car.fastest_command(curvature, st.speed))
        steer = math.degrees(steering_for_curvature(curvature, st.speed, self.car, speed))
        return steer, speed

    def _anticipated_pose(self) -> tuple[float, float, float]:
        """The rear-axle pose [m, m, rad] the car will have when a command given now takes hold: its
        current motion (speed and bend) carried on over the command delay and the yaw lag."""
        st, car = self.env.car_state, self.car
        v = max(st.speed, 0.0)
        tau_y = car.yaw_time_constant + car.yaw_time_constant_per_speed * v
        latency = car.command_delay / car.rate_hz + car.yaw_lag_share * tau_y
        dyaw = st.curvature * v * latency
        heading = st.yaw + 0.5 * dyaw
        return st.x + v * latency * math.cos(heading), st.y + v * latency * math.sin(heading), st.yaw + dyaw

    def __call__(self, observation: Any) -> Any:
        """The action for this step (the observation is ignored)."""
        steer, speed = self.command()
        return self._choose(steer, speed)


def to_action(vehicle: Vehicle, steer: float, speed: float) -> Any:
    """The car's action closest to (steer [deg], speed [m/s]): an index, or a [-1, 1]^2 array."""
    if vehicle.continuous:
        lo, hi = vehicle.steering_range
        s = 2.0 * (min(max(steer, lo), hi) - lo) / (hi - lo) - 1.0
        lo, hi = vehicle.speed_range
        v = 2.0 * (min(max(speed, lo), hi) - lo) / (hi - lo) - 1.0
        return np.array([s, v], dtype=np.float32)
    max_steer = max(vehicle.max_steering, 1e-6)
    max_speed = max(vehicle.max_speed, 1e-6)
    costs = [
        ((a.steering_angle - steer) / max_steer) ** 2 + 0.25 * ((a.speed - speed) / max_speed) ** 2
        for a in vehicle.actions
    ]
    return int(np.argmin(costs))


class ActionChooser:
    """:func:`to_action` for a driver that steers every step: on a discrete action space the steering
    each choice misses by is carried into the next choice (error diffusion), so that a wanted
    steering between two actions' is met on average instead of always rounded to the nearer (a
    driver wanting -7 deg of a car whose actions steer -15, 0 and 15 deg would otherwise never turn).

    :param vehicle: the car whose actions are chosen.
    """

    def __init__(self, vehicle: Vehicle) -> None:
        self.vehicle = vehicle
        self._carried = 0.0  # [deg] steering wanted but not yet given
        self._angles = [a.steering_angle for a in vehicle.actions]  # [deg], per action index
        # what no action can give (past the lock) is not owed
        self._lock = (min(self._angles), max(self._angles)) if self._angles else (0.0, 0.0)

    def __call__(self, steer: float, speed: float) -> Any:
        """The action for (steer [deg], speed [m/s])."""
        if self.vehicle.continuous:
            return to_action(self.vehicle, steer, speed)
        wanted = steer + self._carried
        chosen = to_action(self.vehicle, wanted, speed)
        reachable = max(self._lock[0], min(self._lock[1], wanted))
        self._carried = reachable - self._angles[chosen]
        return chosen


def centre_line_driver(env: Any, speed: float, lookahead: float = 0.35) -> PathFollower:
    """A driver that follows the centre line at one speed [m/s]."""
    track = getattr(env, "unwrapped", env).track
    center = np.asarray(track.center, dtype=float)
    if track.closed and len(center) > 1 and np.allclose(center[0], center[-1]):
        center = center[:-1]
    return PathFollower(env, center, speed, closed=track.closed, lookahead=lookahead)


class ConstantDriver:
    """A driver that always sends the same command, e.g. straight on (and off the first bend).

    :param env: the env (for its car).
    :param steer: [deg] steering.
    :param speed: [m/s] speed.
    """

    def __init__(self, env: Any, steer: float, speed: float) -> None:
        self.action = to_action(getattr(env, "unwrapped", env).vehicle, steer, speed)

    def __call__(self, observation: Any) -> Any:
        """The same action every step."""
        return self.action


def lane_changing_steer(env: Any, lookahead: float = 0.7, margin: float = 0.17, warn: float = 2.0) -> float:
    """:class:`LaneChangingDriver`'s steering [deg] (not clipped to the car's range): pure pursuit
    towards the side of the road away from the nearest object ahead (or still alongside), else
    along the centre line, from the params keys a reward function sees.

    :param env: the env (its car state and ``params`` are read).
    :param lookahead: [m] distance to the aim point (DeepRacer's car answers a command about 0.1 s
        late, so it looks further ahead than a bicycle would need).
    :param margin: [m] the wheels keep this far inside the border.
    :param warn: [m] objects up to this far ahead count.
    """
    e = getattr(env, "unwrapped", env)
    track, st, p = e.track, e.car_state, e.params
    car_s = track.project(p["x"], p["y"]).s
    near = [
        ((d - car_s + 0.5) % track.length - 0.5, left)
        for d, left in zip(p["objects_distance"], p["objects_left_of_center"], strict=True)
    ]
    near = [(ahead, left) for ahead, left in near if -0.45 < ahead < warn]
    s = track.project(st.x, st.y).s + lookahead
    offset = 0.0
    if near:
        _, left = min(near)
        offset = (-1.0 if left else 1.0) * (track.width_at(s) / 2 - margin)
    h = track.heading_at(s)
    tx, ty = track.point_at(s)
    tx, ty = tx - offset * math.sin(h), ty + offset * math.cos(h)
    alpha = math.atan2(ty - st.y, tx - st.x) - st.yaw
    alpha = (alpha + math.pi) % (2 * math.pi) - math.pi
    curvature = 2.0 * math.sin(alpha) / max(math.hypot(tx - st.x, ty - st.y), 1e-6)
    return math.degrees(steering_for_curvature(curvature, st.speed, e.car))


class LaneChangingDriver:
    """A driver that passes boxes and bots: pure pursuit along the side of the road away from
    the nearest object ahead (or still alongside), else along the centre line.

    It reads only what a reward function sees of the objects (``objects_distance``,
    ``objects_left_of_center``), so it shows what a race needs of a policy.

    :param env: the env (its car state and ``params`` are read each step).
    :param speed: [m/s] its one speed.
    :param margin: [m] its wheels keep this far inside the border (half the car's width plus a little).
    :param lookahead: [m] distance to the aim point.
    """

    def __init__(self, env: Any, speed: float, margin: float = 0.17, lookahead: float = 0.7) -> None:
        self.env = getattr(env, "unwrapped", env)
        self.speed = speed
        self.margin = margin
        self.lookahead = lookahead
        self._choose = ActionChooser(self.env.vehicle)

    def command(self) -> tuple[float, float]:
        """The (steering [deg], speed [m/s]) the driver wants now."""
        return lane_changing_steer(self.env, self.lookahead, self.margin), self.speed

    def __call__(self, observation: Any) -> Any:
        """The action for this step (the observation is ignored)."""
        steer, speed = self.command()
        return self._choose(steer, speed)
