"""The theoretical best lap of a car on a track.

``best_lap(track, vehicle)`` = the minimum-curvature racing line
(:mod:`drx.evaluate.racing_line`) driven with the fastest speed profile
(:mod:`drx.evaluate.speed_profile`) under the limits of drx's calibrated car
(:class:`drx.sim.dynamics.CarParams`, fitted to DeepRacer's logs): its top
speed (the fastest action's steady speed), the grip before it slides, the
steering lock whose effect shrinks with speed, and the motor's lag,
acceleration and braking, all taken from the car model rather than set
apart. ``lap_time`` starts from rest at the start line, as every lap of a
DeepRacer evaluation does (see :mod:`drx.evaluate.time_trial`);
``flying_lap_time`` is the same line driven round without stopping.

The minimum-curvature line minimises curvature, not time. That is what a
grip-limited car wants; a car that its top speed rather than grip holds back
everywhere (DeepRacer's default 1 m/s car) is faster on a shorter line. For
such a car :func:`best_lap` also tries blends towards the shortest path
(``SHORTER_LINES``, Braghin et al.'s compromise) that the car can still steer,
and keeps the fastest: on re:Invent 2018 at 1 m/s that is a 15.54 m line
instead of 16.21 m. It remains an estimate from below, not a proof: a lap can
still beat it by a little where the true shortest steerable line is shorter
still. So :func:`best_lap` also drives the line: a scripted driver follows it
at the profile's speeds in drx's simulator (:mod:`drx.evaluate.driven_lap`),
and where it laps faster (on a slightly different path through some bends:
7.07 s against 7.15 s on reInvent2019_track) its lap is the best lap
(``lap_time``; ``estimate_time`` and ``driven_time`` keep both). For fast cars
the driver laps within 0.97-1.05 times the profile (``benchmarks/best_lap.py``).

:func:`racing_line_waypoints` is the extra ``params`` key for reward functions,
``params["racing_line"]`` (:data:`PARAMS_KEY`): the env adds it to every
``params`` dict when made with
``DeepRacerEnv(..., extra_params={PARAMS_KEY: racing_line_waypoints(track)})``
(``track`` in the driving direction of the episode). A DeepRacer reward
function that ignores the key runs unchanged.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from drx.errors import DrxError
from drx.evaluate.racing_line import DEFAULT_SPACING, RacingLine, border_polyline, min_curvature_line
from drx.evaluate.speed_profile import SpeedLimits, lap_time, speed_profile
from drx.sim.dynamics import CarParams
from drx.sim.track import Track
from drx.vehicle import Vehicle

# The params key that carries the racing line (see racing_line_waypoints).
PARAMS_KEY = "racing_line"
# Blends towards the shortest path tried for cars that grip never holds back (see best_lap).
SHORTER_LINES = (0.02, 0.1)
# The minimum-curvature line (a sum of squares) gathers a hairpin's turn into a few points, tighter
# than DeepRacer's car turns at any useful speed (on 2022_reinvent_champ 3.2 /m, 0.31 m, where the car
# turns on 0.58 m at 0.5 m/s), and the car crawls there. best_lap also tries the line whose sharpest bend
# is capped at the car's turning limit at these speeds [m/s] (racing_line's max_curvature: the bend
# spread over the road's width) and keeps the faster lap. Of caps at 0.5, 1, 1.5 and 2 m/s, 1.5 laps
# fastest on 2022_reinvent_champ (13.30 s against 15.75 uncapped), FS_June2020, 2022_june_pro (within
# 0.01 s) and technical, and each cap costs another 1-12 s of solving (2026-11-26).
HAIRPIN_SPEEDS = (1.5,)
# How far [m] the best lap's line keeps the car's centre inside the borders. DeepRacer ends an episode
# only when no wheel is on the road: deepracer-simapp ``markov/reset/rules/off_track_reset_rule.py``
# sets ``is_off_track = not any(points_on_track(...))`` over the four wheel links' origins, and
# ``markov/track_geom/track_data.py``'s ``points_on_track`` asks the road polygon built from the route's
# borders, with no buffer. So the car's centre may run up to half its wheel track (0.081 m) past a
# border, and racers' fast laps do: in simapp 5's logs the car's origin sits up to 0.09-0.115 m past a
# border on steps still in progress. drx's env applies the same rule (``params["is_offtrack"]``). The
# best lap's line keeps the centre 0.04 m inside, the outer wheels 0.04 m past the border: a scripted
# driver cutting inside the line has 0.12 m before the last wheel leaves, and the solver a positive
# corridor (at 0 its distance bounds, blind to the side of a border, let hairpin lines cross it by up
# to 8 cm). Against every wheel kept on (0.081 m), the lap gains 2-6 % (2026-11-26). Reward functions
# get the line that keeps every wheel on the road (racing_line_waypoints).
LAP_LINE_CLEARANCE = 0.04


@dataclass(frozen=True)
class BestLap:
    """The theoretical best lap of a car on a track (an estimate: see the module docstring).

    :param track_name: the track.
    :param car_name: the car.
    :param line: the racing line.
    :param speeds: ``(m,)`` speed [m/s] at each point of the line.
    :param estimate_time: [s] the speed profile's lap from rest at the start line (DeepRacer times
        every lap so).
    :param flying_lap_time: [s] the speed profile's lap already at speed at the line (loops; equal to
        ``estimate_time`` on open tracks).
    :param limits: the limits the lap was computed under.
    :param driven_time: [s] a scripted driver's fastest lap from rest on ``line`` in drx's simulator over
        a few driver settings (:mod:`drx.evaluate.driven_lap`); ``None`` when not driven, or when every
        one left the road.
    """

    track_name: str
    car_name: str
    line: RacingLine
    speeds: np.ndarray
    estimate_time: float
    flying_lap_time: float
    limits: SpeedLimits
    driven_time: float | None = None

    @property
    def lap_time(self) -> float:
        """[s] The best lap from rest at the start line: the faster of the speed profile's and the
        driven lap."""
        return self.estimate_time if self.driven_time is None else min(self.estimate_time, self.driven_time)

    @property
    def line_kind(self) -> str:
        """Which line the lap drives: the minimum-curvature line or a blend towards the shortest path."""
        w = self.line.length_weight
        return "minimum curvature" if w == 0 else f"minimum curvature blended with the shortest path ({w:g})"

    def to_dict(self, with_line: bool = False) -> dict[str, Any]:
        """A JSON-friendly summary; ``with_line`` adds the line's points and speeds."""
        d: dict[str, Any] = {
            "track": self.track_name,
            "car": self.car_name,
            "lap_time": round(self.lap_time, 3),
            "estimate_lap_time": round(self.estimate_time, 3),
            "driven_lap_time": None if self.driven_time is None else round(self.driven_time, 3),
            "flying_lap_time": round(self.flying_lap_time, 3),
            "line_length": round(self.line.length, 3),
            "average_speed": round(self.line.length / self.lap_time, 3),
            "min_speed": round(float(np.min(self.speeds)), 3),
            "max_speed": round(float(np.max(self.speeds)), 3),
            "clearance": round(self.line.clearance, 4),
            "line_kind": self.line_kind,
            "limits": self.limits.to_dict(),
        }
        if with_line:
            d["line"] = [[round(float(x), 4), round(float(y), 4)] for x, y in self.line.points]
            d["speeds"] = [round(float(v), 3) for v in self.speeds]
        return d


def car_limits(vehicle: Vehicle, car: CarParams | None = None) -> SpeedLimits:
    """The limits of ``vehicle`` in drx's simulator, from the car model's own constants.

    :param vehicle: the car (its fastest and slowest commands, its steering lock).
    :param car: the simulator's physical constants (default: :class:`CarParams`).
    """
    p = car or CarParams()
    slowest = float(vehicle.speed_range[0]) if vehicle.continuous else min(a.speed for a in vehicle.actions)
    steer = min(math.radians(vehicle.max_steering), p.max_steering)
    return SpeedLimits(
        top_speed=p.steady_speed(min(vehicle.max_speed, p.max_speed)),  # the speed it settles at
        lateral_accel=p.lateral_accel_max,
        max_acceleration=p.max_acceleration,
        max_braking=p.max_braking,
        time_constant=p.speed_time_constant,
        min_command=p.steady_speed(slowest),
        max_curvature=math.tan(steer) / p.wheelbase if steer > 0 else 0.0,
        time_constant_per_speed=p.speed_time_constant_per_speed,
        steering_gain=p.steering_gain,
        steering_k1=p.steering_speed_k1,
        steering_k2=p.steering_speed_k2,
        wheelbase=p.wheelbase,
        steering_saturation=p.steering_saturation,
        grip_slip=p.grip_slip,
        tyre_shape=p.tyre_shape,
        speed_gain=p.speed_gain,
        speed_offset=p.speed_offset,
    )


def best_lap(
    track: Track,
    vehicle: Vehicle,
    car: CarParams | None = None,
    drive: bool = True,
    speed_scales: Sequence[float] | None = None,
) -> BestLap:
    """The theoretical best lap of ``vehicle`` on ``track`` (see the module docstring): the speed
    profile's estimate on the best line, or, when faster, a scripted driver's fastest lap on that line
    in drx's simulator (``drive``; :mod:`drx.evaluate.driven_lap`: six laps with different driver
    settings, 0.1-0.5 s more; ``speed_scales`` replaces its shares of the profile's speeds).

    :raises DrxError: when every line it tries bends tighter somewhere than the car's steering lock
        allows (:func:`best_lap_on_line`).
    """
    best = _estimated_best_lap(track, vehicle, car)
    if not drive:
        return best
    from drx.evaluate.driven_lap import SPEED_SCALES, driven_lap  # the simulator loads only when driven

    scales = SPEED_SCALES if speed_scales is None else speed_scales
    driven = driven_lap(track, vehicle, best.line.points, best.speeds, car, scales)
    return replace(best, driven_time=driven)


def _estimated_best_lap(track: Track, vehicle: Vehicle, car: CarParams | None) -> BestLap:
    """The speed profile's best lap over the minimum-curvature line, the lines that spread its hairpins
    over the road (:data:`HAIRPIN_SPEEDS`) and, for cars that grip never holds back, blends towards the
    shortest path.

    :raises DrxError: when every one of those lines bends tighter than the car's steering lock allows.
    """
    p = car or CarParams()
    limits = car_limits(vehicle, p)
    half_width = LAP_LINE_CLEARANCE
    line = cached_racing_line(track, half_width)
    lines = [line]
    sharpest = _sharpest(line)
    for speed in HAIRPIN_SPEEDS:  # lines whose sharpest bend the car turns at these speeds
        cap = float(limits.turning_curvature(np.array([speed]))[0])
        if cap < sharpest:
            lines.append(cached_racing_line(track, half_width, max_curvature=cap))
    # Only a line the car can steer counts. The minimum-curvature line alone may not be one: where a
    # hairpin wraps round the sharp tip of a border (hamption_open's, 0.08 m radius at the centre line),
    # the sum of squares gathers the turn into one or two points, 4.9 /m against the 3.5 /m of 30 degrees
    # of lock, while the capped line spreads it over the road's width (1.3 /m).
    steerable = [c for c in lines if _sharpest(c) <= limits.max_curvature]
    if not steerable:
        raise _steering_error(min(lines, key=_sharpest), limits, track.name, vehicle.name)
    laps = [best_lap_on_line(c, limits, track_name=track.name, car_name=vehicle.name) for c in steerable]
    best = min(laps, key=lambda lap: lap.lap_time)  # the first of equals: the minimum-curvature line
    if not _top_speed_bound(line, limits):
        return best
    for weight in SHORTER_LINES:  # a car grip never holds back is faster on a shorter line
        shorter = cached_racing_line(track, half_width, weight)
        if _sharpest(shorter) > limits.tightest_curvature:
            continue
        lap = best_lap_on_line(shorter, limits, track_name=track.name, car_name=vehicle.name)
        if lap.lap_time < best.lap_time:
            best = lap
    return best


def _sharpest(line: RacingLine) -> float:
    """The curvature [1/m] of the line's sharpest bend."""
    return float(np.max(np.abs(line.curvature)))


def _top_speed_bound(line: RacingLine, limits: SpeedLimits) -> bool:
    """Whether grip never limits the car on ``line`` (its top speed is below every bend's grip speed)."""
    tightest = _sharpest(line)
    if tightest <= 0:
        return True
    return tightest <= float(limits.turning_curvature(np.array([limits.top_speed]))[0])


def best_lap_on_line(
    line: RacingLine, limits: SpeedLimits, track_name: str = "", car_name: str = ""
) -> BestLap:
    """Drive a given racing line as fast as ``limits`` allow.

    A bend tighter than the calibrated car's tightest turn (``limits.tightest_curvature``) is taken at
    the car's slowest speed, where DeepRacer's car runs a little wide of any line (its logs show it
    lapping such tracks all the same).

    :raises DrxError: when the line bends tighter than the car's steering lock allows even an ideal
        bicycle (``limits.max_curvature``): the car's steering range is too small for the track.
    """
    if _sharpest(line) > limits.max_curvature:
        raise _steering_error(line, limits, track_name, car_name)
    ds = line.segment_lengths
    speeds = speed_profile(ds, line.curvature, line.closed, limits, start_speed=0.0)
    standing = lap_time(ds, speeds, line.closed)
    flying = standing
    if line.closed:
        flying = lap_time(ds, speed_profile(ds, line.curvature, line.closed, limits), line.closed)
    return BestLap(
        track_name=track_name,
        car_name=car_name,
        line=line,
        speeds=speeds,
        estimate_time=standing,
        flying_lap_time=flying,
        limits=limits,
    )


def _steering_error(line: RacingLine, limits: SpeedLimits, track_name: str, car_name: str) -> DrxError:
    """The error for a car whose steering lock cannot bend its path as tightly as ``line`` bends."""
    need = math.degrees(math.atan(_sharpest(line) * limits.wheelbase))
    return DrxError(
        f"Car {car_name or '?'} cannot drive track {track_name or '?'}: its tightest bend needs about "
        f"{need:.0f} degrees of steering and the car steers at most {math.degrees(_lock(limits)):.0f}."
    )


def _lock(limits: SpeedLimits) -> float:
    """The steering lock [rad] behind ``limits.max_curvature`` (for messages)."""
    return math.atan(limits.max_curvature * limits.wheelbase)


def racing_line_waypoints(track: Track, car: CarParams | None = None) -> list[tuple[float, float]]:
    """The racing line as a list of ``(x, y)`` waypoints, for reward functions.

    This is the value of the extra ``params["racing_line"]`` key: the
    minimum-curvature line of :func:`min_curvature_line` that keeps the car's
    half-width clear of both borders, as many points as the track's
    ``waypoints`` (so index ``i`` of one is near index ``i`` of the other),
    in driving order, with the closing duplicate on loops. Computed once per
    track and car width, then cached (about 0.1-1 s per track).

    The line's points are 0.1-0.17 m apart, the track's waypoints up to 0.6 m:
    the resampling's chords cut across the bends, by up to 1.6 cm at the apexes
    of penbay_pro's and red_star_pro's, so the few points they pushed closer than
    the car's half-width to a border are moved back out
    (:meth:`RacingLine.waypoints`' ``borders``).
    """
    p = car or CarParams()
    line = cached_racing_line(track, 0.5 * p.track_width)
    count = len(track.center) - (1 if track.closed else 0)
    borders = (border_polyline(track.inner, track.closed), border_polyline(track.outer, track.closed))
    return line.waypoints(count=count, borders=borders)


def cached_racing_line(
    track: Track, half_width: float, length_weight: float = 0.0, max_curvature: float | None = None
) -> RacingLine:
    """:func:`min_curvature_line` for ``track``, cached by geometry, ``half_width``, ``length_weight`` and
    ``max_curvature``."""
    digest = hashlib.sha1(np.ascontiguousarray(np.hstack([track.center, track.inner, track.outer])).tobytes())
    cap = None if max_curvature is None else round(max_curvature, 6)
    key = (digest.hexdigest(), bool(track.closed), round(half_width, 6), round(length_weight, 6), cap)
    line = _LINES.get(key)
    if line is None:
        line = min_curvature_line(
            track.center,
            track.inner,
            track.outer,
            track.closed,
            half_width,
            spacing=DEFAULT_SPACING,
            length_weight=length_weight,
            max_curvature=max_curvature,
        )
        if len(_LINES) >= _CACHE_SIZE:
            _LINES.pop(next(iter(_LINES)))
        _LINES[key] = line
    return line


_CACHE_SIZE = 32
_LINES: dict[tuple[str, bool, float, float, float | None], RacingLine] = {}
