"""A best lap checked by driving it: a scripted driver on the racing line in drx's simulator.

The speed profile (:mod:`drx.evaluate.speed_profile`) estimates the best lap from the car model's
steady limits on the minimum-curvature line; a pure-pursuit driver following that line at those
speeds, in the simulator itself, shows what the car actually does there. Where it is faster (it
takes a slightly different path through some bends, where the car's turning limit falls steeply
with speed: 7.07 s against 7.15 s on reInvent2019_track, 2026-11-26), the lap it drove is a lap
the car can drive, so the theoretical best lap is at most that (issue 10: "derive the solver's limits from
the car model, or verify its lap by driving it in the simulator").
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from drx.evaluate.scripted import PathFollower
from drx.evaluate.time_trial import RaceRules, max_steps_for, run_time_trial
from drx.sim.dynamics import CarParams
from drx.sim.env import DeepRacerEnv
from drx.sim.track import Track
from drx.vehicle import Vehicle

# DeepRacer's car answers ~0.1 s late: the driver steers from where the car will be when the command
# takes hold, and looks further ahead the faster it goes (LOOKAHEAD_TIMES of travel, LOOKAHEAD at least).
# At the grip limit one setting is not right for every track (tried on the shared tracks, 2026-11-23:
# 0.4 s laps fastest on most, but leaves Bowtie_track's road at the profile's speeds; 0.45 s laps
# FS_June2020 1.6 % faster and leaves Bowtie's too), so the driver drives the line with each of a few
# settings, also a little under the profile's speeds, and the fastest lap that stays on the road counts:
# a small search over drivers, as a driver learns a track.
LOOKAHEAD = 0.6  # [m]
LOOKAHEAD_TIMES = (0.35, 0.4, 0.45)  # [s]
SPEED_SCALES = (0.95, 1.0)  # [-] of the speed profile
TIME_CAP_MINUTES = 5.0


def driven_lap(
    track: Track,
    vehicle: Vehicle,
    line: np.ndarray,
    speeds: np.ndarray,
    car: CarParams | None = None,
    speed_scales: Sequence[float] = SPEED_SCALES,
) -> float | None:
    """The fastest lap [s] a pure-pursuit driver drives from rest at the start line, following ``line``
    at ``speeds`` times each of ``speed_scales`` with each of :data:`LOOKAHEAD_TIMES`, in drx's
    simulator with its noise off (one-lap time trials), or ``None`` when every one leaves the road or
    does not finish.

    :param track: the track.
    :param vehicle: the car (its actions or ranges bound the driver's commands).
    :param line: ``(m, 2)`` the path to follow [m].
    :param speeds: ``(m,)`` the speed wanted at each of its points [m/s].
    :param car: the car model (default :class:`CarParams`).
    :param speed_scales: the shares of ``speeds`` to drive at (default :data:`SPEED_SCALES`: the
        profile's speeds and a little under; above 1 the driver pushes past the profile, which its
        steady limits do not always bound, and finds how much faster the car can lap).
    """
    rules = RaceRules(laps=1, time_cap_minutes=TIME_CAP_MINUTES)
    env = DeepRacerEnv(
        track=track, vehicle=vehicle, car=car, mode="evaluation", max_steps=max_steps_for(rules),
        deterministic=True,
    )  # fmt: skip
    times = []
    try:
        for lookahead_time in LOOKAHEAD_TIMES:
            for scale in speed_scales:
                driver = PathFollower(
                    env, line, speeds * scale, closed=track.closed, lookahead=LOOKAHEAD,
                    lookahead_time=lookahead_time,
                )  # fmt: skip
                laps = run_time_trial(env, driver, rules).complete_laps
                if laps and not laps[0].off_track_count and laps[0].time is not None:
                    times.append(float(laps[0].time))
    finally:
        env.close()
    return min(times) if times else None
