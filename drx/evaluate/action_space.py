"""A discrete action space derived from a track's racing line.

The fastest virtual racers do not use DeepRacer's steering x speed grid: they take the commands the
track's racing line asks for and cluster them into a custom action list. The method comes from the
community: cdthompson's K1999 race lines for DeepRacer's tracks
(https://github.com/cdthompson/deepracer-k1999-race-lines, Rémi Coulom's K1999 minimum-curvature
line), then dgnzlz's notebook ``Compute_Speed_And_Actions/RaceLine_Speed_ActionSpace.ipynb``
(https://github.com/dgnzlz/Capstone_AWS_DeepRacer, "An Advanced Guide to AWS DeepRacer", 2020),
which gives every point of that line a speed from its radius and a steering angle, and clusters the
(steering, speed) pairs with K-means into the custom action space.

drx does the same with its own pieces:

1. **The line and its speeds.** drx's theoretical best lap (:func:`drx.evaluate.theoretical_lap.best_lap`,
   undriven): the minimum-curvature line (or the variant that laps faster for this car) and the
   forward-backward speed profile under the limits of drx's calibrated car. Loops use the *flying*
   lap's profile (the lap at speed, which laps 2 and 3 of a time trial and most of training drive);
   open tracks start from rest, as they can only be driven.
2. **The commands.** An action is a command, not a state, so each point gets the command drx's own
   line-following driver (:class:`drx.evaluate.scripted.PathFollower`) would give there: full
   throttle where the profile accelerates (no more than leaves the slipping wheels the grip of the
   bend, :meth:`~drx.sim.dynamics.CarParams.fastest_command`), else the command that holds the
   profile's speed (:meth:`~drx.sim.dynamics.CarParams.holding_command`); and the steering that bends
   the car's path to the line's curvature at that speed in drx's car model
   (:func:`drx.sim.dynamics.steering_for_curvature`). That steering is not the bicycle's
   ``atan(wheelbase * curvature)`` the notebook uses: DeepRacer's understeering car needs about three
   times that (on A to Z Speedway the line's sharpest bend asks for 30 degrees, a bicycle 11).
3. **The clusters.** K-means (Lloyd's algorithm, k-means++ starts from a seeded generator, the best of
   a few restarts: deterministic) on the commands scaled to the car's ranges (steering over
   twice the lock, speed over the top speed), with some centres held fixed, which is why it is
   NumPy here rather than scikit-learn's ``KMeans``: a straight-ahead action at the top speed (full
   throttle on the straights), and for each turning direction the line steers to by at least
   :data:`MIN_TURN` degrees, its sharpest point (the most lock it needs there, at the slowest speed
   it needs it), so that the actions reach both ways as far as the line does; k-means' means alone
   would fall short of the extremes.

The result is a custom action list within DeepRacer's limits (2-30 actions, -30..30 degrees,
0.1..4 m/s), ordered as the console orders its grid: by steering from left to right, then by speed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from drx.errors import DrxError
from drx.evaluate.speed_profile import speed_profile
from drx.evaluate.theoretical_lap import BestLap, best_lap
from drx.sim.dynamics import CarParams, steering_for_curvature
from drx.sim.track import Track
from drx.vehicle import CUSTOM_ACTIONS_RANGE, SPEED_LIMIT, STEERING_LIMIT, Action, Vehicle

DEFAULT_ACTIONS = 15  # racers' action lists hold 10-20; 15 is what race_pace.py's discrete car has
MIN_TURN = 2.0  # [deg] a turning direction the line steers to by less than this is not one it needs
RESTARTS = 8  # k-means++ starts; the lowest sum of squared distances is kept
ITERATIONS = 100  # Lloyd iterations at most per start (a few dozen suffice for a few hundred points)
STEERING_DECIMALS = 1  # [deg] the actions' resolution: 0.1 degree
SPEED_DECIMALS = 2  # [m/s] 0.01 m/s


@dataclass(frozen=True)
class LineActionSpace:
    """An action space clustered from a racing line's commands.

    :param track_name: the track.
    :param actions: the clustered actions, in the console's order (left to right, then slow to fast).
    :param steering: ``(m,)`` the steering command [deg] at each point of the line.
    :param speeds: ``(m,)`` the speed command [m/s] at each point of the line.
    :param nearest: ``(m,)`` the index of each point's nearest action (in the scaled metric).
    :param max_steering: [deg] the car's lock the steering was scaled and capped by.
    :param max_speed: [m/s] the car's top speed the speeds were scaled and capped by.
    :param lap: the best lap whose line and speeds the actions come from.
    """

    track_name: str
    actions: tuple[Action, ...]
    steering: np.ndarray
    speeds: np.ndarray
    nearest: np.ndarray
    max_steering: float
    max_speed: float
    lap: BestLap

    def distances(self) -> np.ndarray:
        """``(m,)`` each point's distance to its nearest action, in the scaled metric (steering over
        twice the lock, speed over the top speed: 0.1 is 6 degrees at a 30-degree lock, or 0.4 m/s at 4)."""
        points = _scaled(self.steering, self.speeds, self.max_steering, self.max_speed)
        centres = _scaled(
            np.array([a.steering_angle for a in self.actions]),
            np.array([a.speed for a in self.actions]),
            self.max_steering,
            self.max_speed,
        )
        return np.sqrt(np.min(_squared_distances(points, centres), axis=1))

    def largest_miss(self) -> tuple[float, float]:
        """How far the point farthest from its nearest action is from it: (steering [deg], speed [m/s])."""
        worst = int(np.argmax(self.distances()))
        action = self.actions[int(self.nearest[worst])]
        return (
            abs(float(self.steering[worst]) - action.steering_angle),
            abs(float(self.speeds[worst]) - action.speed),
        )

    def to_dict(self) -> dict[str, Any]:
        """A JSON-friendly summary: where the actions come from and how well they cover the line."""
        steer_miss, speed_miss = self.largest_miss()
        distances = self.distances()
        return {
            "track": self.track_name,
            "actions": len(self.actions),
            "points": int(len(self.steering)),
            "line_length": round(self.lap.line.length, 3),
            "lap_time": round(self.lap.lap_time, 3),
            "line_kind": self.lap.line_kind,
            "steering_range": [round(float(self.steering.min()), 1), round(float(self.steering.max()), 1)],
            "speed_range": [round(float(self.speeds.min()), 2), round(float(self.speeds.max()), 2)],
            "largest_distance": round(float(distances.max()), 4),
            "mean_distance": round(float(distances.mean()), 4),
            "largest_steering_miss": round(steer_miss, 1),
            "largest_speed_miss": round(speed_miss, 2),
        }


def racing_line_actions(
    track: Track,
    count: int = DEFAULT_ACTIONS,
    max_steering: float = STEERING_LIMIT,
    max_speed: float = SPEED_LIMIT[1],
    car: CarParams | None = None,
    seed: int = 0,
    car_name: str = "racing-line",
) -> LineActionSpace:
    """``count`` discrete actions clustered from the commands of drx's racing line on ``track`` (see the
    module docstring).

    :param track: the track, in its driving direction.
    :param count: the number of actions, 2 to 30 (DeepRacer's custom action lists).
    :param max_steering: [deg] the car's steering lock, 1 to 30: the line is solved for it and no
        action steers further.
    :param max_speed: [m/s] the car's top speed, 0.1 to 4: no action is faster, and the straight-ahead
        action is this fast.
    :param car: drx's car model (default :class:`CarParams`).
    :param seed: the k-means++ generator's seed (the same seed gives the same actions).
    :param car_name: the car's name, for the message when it cannot steer the track.
    :raises DrxError: ``count`` out of range; the line needs more actions than ``count`` to keep a
        straight-ahead action and both turning directions, or has fewer distinct commands than
        ``count``; or the car cannot steer the track (:func:`~drx.evaluate.theoretical_lap.best_lap`).
    """
    lo, hi = CUSTOM_ACTIONS_RANGE
    if not lo <= count <= hi:
        raise DrxError(f"An action space from the racing line needs {lo} to {hi} actions, not {count}.")
    p = car or CarParams()
    lap, steering, speeds = line_commands(track, max_steering, max_speed, p, car_name)
    fixed = _fixed_actions(steering, speeds, max_speed)
    if count < len(fixed):
        raise DrxError(
            f"The racing line of {track.name} turns both ways, so its action space needs a straight-ahead "
            f"action and one for each direction: give at least {len(fixed)} actions, not {count}."
        )
    rounded = {_round(s, v) for s, v in zip(steering, speeds, strict=True)} | {_round(s, v) for s, v in fixed}
    if len(rounded) < count:
        raise DrxError(
            f"The racing line of {track.name} asks for only {len(rounded)} distinct commands; "
            f"give at most {len(rounded)} actions, not {count}."
        )
    points = _scaled(steering, speeds, max_steering, max_speed)
    anchors = _scaled(
        np.array([s for s, _ in fixed]), np.array([v for _, v in fixed]), max_steering, max_speed
    )
    centres = kmeans_with_fixed(points, anchors, count, seed=seed)
    raw = [
        Action(*_round(float(c[0] * 2.0 * max_steering), float(c[1] * max_speed), max_steering, max_speed))
        for c in centres
    ]
    actions = tuple(sorted(set(raw), key=lambda a: (-a.steering_angle, a.speed)))
    if len(actions) < count:  # two means rounded to one action: only when the commands barely differ
        raise DrxError(
            f"The racing line of {track.name} has too few distinct commands for {count} actions; "
            f"give fewer with --actions."
        )
    scaled_actions = _scaled(
        np.array([a.steering_angle for a in actions]),
        np.array([a.speed for a in actions]),
        max_steering,
        max_speed,
    )
    nearest = np.argmin(_squared_distances(points, scaled_actions), axis=1)
    return LineActionSpace(
        track_name=track.name,
        actions=actions,
        steering=steering,
        speeds=speeds,
        nearest=nearest,
        max_steering=max_steering,
        max_speed=max_speed,
        lap=lap,
    )


def line_commands(
    track: Track,
    max_steering: float,
    max_speed: float,
    car: CarParams | None = None,
    car_name: str = "racing-line",
) -> tuple[BestLap, np.ndarray, np.ndarray]:
    """The best lap of a car with ``max_steering`` [deg] and ``max_speed`` [m/s] on ``track``, and the
    steering [deg] and speed [m/s] commands at each point of its line (module docstring, steps 1-2).

    :param track: the track, in its driving direction.
    :param max_steering: [deg] the car's steering lock.
    :param max_speed: [m/s] the car's top speed.
    :param car: drx's car model (default :class:`CarParams`).
    :param car_name: the car's name, for the message when it cannot steer the track.
    :raises DrxError: the car cannot steer the track's line (:func:`best_lap`).
    """
    p = car or CarParams()
    # The solver reads a car's lock, top speed and slowest command: DeepRacer's slowest (0.1 m/s) lets the
    # profile brake as hard as the car can; the clustered actions' slowest is the bends' own speed.
    probe = Vehicle(
        name=car_name, actions=(Action(max_steering, max_speed), Action(-max_steering, SPEED_LIMIT[0]))
    )
    lap = best_lap(track, probe, car=p, drive=False)
    line = lap.line
    if line.closed:  # the flying lap: the lap at speed
        speeds = speed_profile(line.segment_lengths, line.curvature, True, lap.limits, start_speed=None)
    else:
        speeds = np.asarray(lap.speeds, dtype=float)
    following = np.roll(speeds, -1) if line.closed else np.append(speeds[1:], speeds[-1])
    steering = np.empty(len(speeds))
    commands = np.empty(len(speeds))
    for i, (kappa, v) in enumerate(zip(line.curvature, speeds, strict=True)):
        k, speed = float(kappa), float(v)
        if following[i] > speed + 1e-6:  # accelerating: full throttle, as far as the bend's grip allows
            command = min(max_speed, p.fastest_command(k, speed))
        else:  # braking or holding: the command the car settles at the profile's speed under
            command = min(max_speed, p.holding_command(speed))
        commands[i] = max(command, SPEED_LIMIT[0])
        steering[i] = math.degrees(steering_for_curvature(k, speed, p, commands[i]))
    return lap, np.clip(steering, -max_steering, max_steering), commands


def kmeans_with_fixed(
    points: np.ndarray, fixed: np.ndarray, count: int, seed: int = 0, restarts: int = RESTARTS
) -> np.ndarray:
    """``count`` centres for ``points``: the ``fixed`` ones, then k-means' (Lloyd's algorithm from
    k-means++ starts, ``restarts`` of them from one seeded generator; the start with the smallest sum
    of squared distances wins). Fixed centres take their points like any other but never move.

    :param points: ``(m, d)`` points.
    :param fixed: ``(f, d)`` centres that stay where they are (``f <= count``).
    :param count: the number of centres.
    :param seed: the generator's seed (deterministic for a seed).
    :param restarts: k-means++ starts.
    :return: ``(count, d)`` centres, the fixed first.
    """
    rng = np.random.default_rng(seed)
    f = len(fixed)
    best: tuple[float, np.ndarray] | None = None
    for _ in range(max(1, restarts)):
        centres = _plus_plus(points, fixed, count, rng)
        for _ in range(ITERATIONS):
            labels = np.argmin(_squared_distances(points, centres), axis=1)
            moved = centres.copy()
            for j in range(f, count):
                members = points[labels == j]
                if len(members):
                    moved[j] = members.mean(axis=0)
                else:  # an empty cluster restarts at the point worst served (standard practice)
                    moved[j] = points[int(np.argmax(np.min(_squared_distances(points, moved), axis=1)))]
            if np.allclose(moved, centres, atol=1e-12):
                break
            centres = moved
        inertia = float(np.sum(np.min(_squared_distances(points, centres), axis=1)))
        if best is None or inertia < best[0] - 1e-12:
            best = (inertia, centres)
    assert best is not None
    return best[1]


def _plus_plus(points: np.ndarray, fixed: np.ndarray, count: int, rng: np.random.Generator) -> np.ndarray:
    """k-means++ starts (Arthur & Vassilvitskii 2007): each new centre drawn with probability in
    proportion to its squared distance from the centres so far, the fixed ones first."""
    centres = [np.asarray(c, dtype=float) for c in fixed]
    if not centres:
        centres.append(points[int(rng.integers(len(points)))])
    while len(centres) < count:
        d2 = np.min(_squared_distances(points, np.array(centres)), axis=1)
        total = float(d2.sum())
        if total <= 0.0:  # every point already sits on a centre: any point will do
            centres.append(points[int(rng.integers(len(points)))])
        else:
            centres.append(points[int(rng.choice(len(points), p=d2 / total))])
    return np.array(centres, dtype=float)


def _fixed_actions(steering: np.ndarray, speeds: np.ndarray, max_speed: float) -> list[tuple[float, float]]:
    """The actions the space keeps whatever the clusters: straight ahead at the top speed, and per turning
    direction the line needs (by at least :data:`MIN_TURN`) its sharpest point, at the slowest speed
    among the points within a degree of that steering (full lock in a hairpin is needed at its apex
    speed, and the slowest such action is also the one to brake with)."""
    fixed = [(0.0, max_speed)]
    for side in (1.0, -1.0):  # left (positive) first, as the console orders its actions
        turned = side * steering
        extreme = float(turned.max())
        if extreme < MIN_TURN:
            continue
        near = turned >= extreme - 1.0
        slowest = int(np.flatnonzero(near)[np.argmin(speeds[near])])
        fixed.append((float(steering[slowest]), float(speeds[slowest])))
    return fixed


def _scaled(steering: np.ndarray, speeds: np.ndarray, max_steering: float, max_speed: float) -> np.ndarray:
    """``(m, 2)`` commands in k-means' units: steering over the car's steering span (twice its lock), speed
    over its top speed, so that both spread over about the same length."""
    return np.column_stack([np.asarray(steering) / (2.0 * max_steering), np.asarray(speeds) / max_speed])


def _squared_distances(points: np.ndarray, centres: np.ndarray) -> np.ndarray:
    """``(m, k)`` squared distances from each point to each centre."""
    diff = points[:, None, :] - centres[None, :, :]
    return np.asarray(np.sum(diff * diff, axis=2))


def _round(
    steering: float, speed: float, max_steering: float = STEERING_LIMIT, max_speed: float = SPEED_LIMIT[1]
) -> tuple[float, float]:
    """A command at the actions' resolution, within the car's and DeepRacer's limits (+0.0, never -0.0)."""
    s = round(min(max(steering, -max_steering), max_steering), STEERING_DECIMALS) + 0.0
    v = round(min(max(speed, SPEED_LIMIT[0]), max_speed), SPEED_DECIMALS) + 0.0
    return s, v
