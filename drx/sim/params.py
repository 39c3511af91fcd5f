"""DeepRacer's reward ``params``: the one place they are computed.

The env calls :func:`compute_params` on every reset and step, and
``drx reward validate`` runs the user's function on :func:`sample_params_cases`,
so both see the same numbers (``../shared/DEEPRACER.md`` section 3).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from drx.sim.dynamics import CarParams, rear_axle_from_reference, wheel_positions
from drx.sim.episode_status import EpisodeStatus
from drx.sim.objects import no_objects
from drx.sim.track import Projection, Track

PARAM_KEYS = (
    "all_wheels_on_track", "x", "y", "heading", "distance_from_center", "is_left_of_center",
    "is_offtrack", "is_crashed", "is_reversed", "progress", "speed", "steering_angle", "steps",
    "track_length", "track_width", "waypoints", "closest_waypoints", "closest_objects",
    "objects_location", "objects_left_of_center", "objects_speed", "objects_heading", "objects_distance",
)  # fmt: skip


def compute_params(
    track: Track,
    *,
    x: float,
    y: float,
    heading: float,
    speed: float,
    steering_angle: float,
    steps: int,
    progress: float,
    wheels_on_track: Sequence[bool],
    projection: Projection | None = None,
    is_crashed: bool = False,
    is_reversed: bool = False,
    objects: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """Build the ``params`` dict a DeepRacer reward function receives.

    :param track: the track, in the driving direction of the episode.
    :param x: reference point x [m] (0.14 m ahead of the rear axle).
    :param y: reference point y [m].
    :param heading: yaw [deg], -180..180.
    :param speed: commanded speed of the action taken [m/s].
    :param steering_angle: commanded steering [deg], + = left.
    :param steps: steps in this episode (1 on the first step).
    :param progress: percent of the lap done from the episode's start point, 0..100.
    :param wheels_on_track: one bool per wheel.
    :param projection: ``track.project(x, y)`` when the caller already has it.
    :param is_crashed: the car hit an object.
    :param is_reversed: the track is driven in its reverse direction.
    :param objects: the object keys (``closest_objects``, ``objects_*``) of a race with boxes or bots,
        as :meth:`drx.sim.race_scene.RaceScene.params` builds them; ``None`` for a time trial.
    """
    proj = projection if projection is not None else track.project(x, y)
    all_on = all(wheels_on_track)
    params = {
        "all_wheels_on_track": all_on,
        "x": float(x),
        "y": float(y),
        "heading": float(heading),
        "distance_from_center": proj.distance,
        "is_left_of_center": proj.left,
        "is_offtrack": not any(wheels_on_track),
        "is_crashed": bool(is_crashed),
        "is_reversed": bool(is_reversed),
        "progress": float(progress),
        "speed": float(speed),
        "steering_angle": float(steering_angle),
        "steps": int(steps),
        "track_length": track.length,
        "track_width": proj.width,
        # A shallow copy (< 1 µs): a reward that sorts or pops it cannot corrupt the track.
        "waypoints": list(track.waypoints),
        "closest_waypoints": [proj.prev_index, proj.next_index],
        # No race objects: DeepRacer's values for a time trial.
        **no_objects(),
    }
    if objects:
        params.update(objects)
    return params


def params_at_pose(
    track: Track,
    x: float,
    y: float,
    heading_deg: float,
    *,
    speed: float = 1.0,
    steering_angle: float = 0.0,
    steps: int = 1,
    progress: float = 0.0,
    car: CarParams | None = None,
    scene: Any = None,
) -> dict[str, Any]:
    """``params`` for a car whose reference point is at (x, y) with the given heading [deg].

    :param scene: a :class:`drx.sim.race_scene.RaceScene` whose objects fill the object keys and
        ``is_crashed`` (``None``: a time trial).
    """
    car = car or CarParams()
    yaw = math.radians(heading_deg)
    rx, ry = rear_axle_from_reference(x, y, yaw, car)
    wheels = [track.on_road_xy(wx, wy) for wx, wy in wheel_positions(rx, ry, yaw, car)]
    proj = track.project(x, y)
    crashed = scene is not None and scene.hit(rx, ry, yaw) is not None
    objects = scene.params(proj.s) if scene is not None else None
    return compute_params(
        track, x=x, y=y, heading=heading_deg, speed=speed, steering_angle=steering_angle, steps=steps,
        progress=progress, wheels_on_track=wheels, projection=proj, is_crashed=crashed, objects=objects,
    )  # fmt: skip


def _pose_at(track: Track, s: float, offset: float) -> tuple[float, float, float]:
    """Reference point ``offset`` m left of the centre line at ``s``, heading along the track [deg]."""
    cx, cy = track.point_at(s)
    h = float(track.heading_at(s))
    return float(cx - offset * math.sin(h)), float(cy + offset * math.cos(h)), math.degrees(h)


def sample_params_cases(
    track: Track, car: CarParams | None = None, race: Any = None
) -> dict[str, dict[str, Any]]:
    """Sample states for ``drx reward validate``: start line, mid-lap near each border, off track,
    lap complete. Each is the ``params`` dict the env would compute there.

    :param race: a :class:`drx.settings.race.RaceConfig` (or its dict); with boxes or bots every case
        carries the object keys, and a ``crashed`` case (the car against the first object) is added.
    """
    car = car or CarParams()
    scene = _scene(track, car, race)
    length = track.length
    mid = 0.5 * length
    half = 0.5 * track.width_at(mid)
    near = max(half - 0.5 * car.track_width - 0.03, 0.0)  # wheels still on the road
    cases: dict[str, dict[str, Any]] = {}
    # On an open track the rear wheels must still be on the road at the start.
    start = 0.0 if track.closed else car.reference_offset + 0.02
    x, y, h = _pose_at(track, start, 0.0)
    cases["start"] = params_at_pose(track, x, y, h, speed=1.0, steps=1, progress=0.0, car=car, scene=scene)
    steps_mid = max(int(mid / 1.0 * car.rate_hz), 2)
    x, y, h = _pose_at(track, mid, near)
    cases["mid_lap_left"] = params_at_pose(
        track, x, y, h, speed=2.0, steering_angle=15.0, steps=steps_mid, progress=50.0, car=car, scene=scene
    )
    x, y, h = _pose_at(track, mid, -near)
    cases["mid_lap_right"] = params_at_pose(
        track, x, y, h, speed=2.0, steering_angle=-15.0, steps=steps_mid, progress=50.0, car=car, scene=scene
    )
    outside = -1.0 if track.direction == "ccw" else 1.0  # away from the infield
    for extra in (0.3, 0.5, 1.0, 2.0):
        x, y, h = _pose_at(track, mid, outside * (half + extra))
        case = params_at_pose(
            track, x, y, h, speed=1.0, steering_angle=30.0, steps=steps_mid + 1, progress=50.0, car=car,
            scene=scene,
        )  # fmt: skip
        if case["is_offtrack"]:
            break
    cases[EpisodeStatus.OFF_TRACK] = case
    end = length - 1e-6 if not track.closed else 0.0
    x, y, h = _pose_at(track, end, 0.0)
    cases[EpisodeStatus.LAP_COMPLETE] = params_at_pose(
        track, x, y, h, speed=1.0, steps=int(length * car.rate_hz), progress=100.0, car=car, scene=scene
    )
    if scene is not None and scene.objects:
        obj = scene.objects[0]
        s = obj.s - 0.5 * obj.crash[0]  # the car's nose at the object's crash footprint
        x, y, h = _pose_at(track, s, obj.offset)
        frac = 100.0 * s / length
        cases[EpisodeStatus.CRASHED] = params_at_pose(
            track, x, y, h, speed=1.0, steps=int(s * car.rate_hz) + 1, progress=frac, car=car, scene=scene
        )
    return cases


def _scene(track: Track, car: CarParams, race: Any) -> Any:
    """The race's objects as placed at the start of an evaluation (``None`` for a time trial)."""
    if race is None:
        return None
    import numpy as np

    from drx.settings.race import RaceConfig
    from drx.sim.race_scene import RaceScene

    config = race if isinstance(race, RaceConfig) else RaceConfig.from_dict(race)
    if not config.has_objects:
        return None
    scene = RaceScene(track, config, car)
    scene.reset(np.random.default_rng(0), 0.0, training=False)
    return scene
