"""A best lap checked by driving it: a scripted driver on the racing line in drx's simulator.

The speed profile (:mod:`drx.evaluate.speed_profile`) estimates the best lap from the car model's
steady limits on the minimum-curvature line; a pure-pursuit driver following that line at those
speeds, in the simulator itself, shows what the car actually does there. Where it is faster (it
takes a slightly different path through some bends, where the car's turning limit falls steeply
with speed: 7.40 s against 7.52 s on reInvent2019_track), the lap it drove is a lap the car can
drive, so the theoretical best lap is at most that (issue 10: "derive the solver's limits from
the car model, or verify its lap by driving it in the simulator").
"""

from __future__ import annotations

import numpy as np

from drx.evaluate.scripted import PathFollower
from drx.evaluate.time_trial import RaceRules, max_steps_for, run_time_trial
from drx.sim.dynamics import CarParams
from drx.sim.env import DeepRacerEnv
from drx.sim.track import Track
from drx.vehicle import Vehicle

# DeepRacer's car answers ~0.1 s late: the driver steers from where the car will be when the command
# takes hold, and looks further ahead the faster it goes (0.4 s of travel, 0.6 m at least): of 0.2-0.6 s
# tried on the shared tracks (2026-11-22), 0.4 s lapped fastest, and from 0.5 s the driver weaved off.
LOOKAHEAD = 0.6  # [m]
LOOKAHEAD_TIME = 0.4  # [s]
TIME_CAP_MINUTES = 5.0


def driven_lap(
    track: Track, vehicle: Vehicle, line: np.ndarray, speeds: np.ndarray, car: CarParams | None = None
) -> float | None:
    """The lap [s] a pure-pursuit driver drives from rest at the start line, following ``line`` at
    ``speeds`` in drx's simulator with its noise off (a one-lap time trial), or ``None`` when it
    leaves the road or does not finish.

    :param track: the track.
    :param vehicle: the car (its actions or ranges bound the driver's commands).
    :param line: ``(m, 2)`` the path to follow [m].
    :param speeds: ``(m,)`` the speed wanted at each of its points [m/s].
    :param car: the car model (default :class:`CarParams`).
    """
    rules = RaceRules(laps=1, time_cap_minutes=TIME_CAP_MINUTES)
    env = DeepRacerEnv(
        track=track, vehicle=vehicle, car=car, mode="evaluation", max_steps=max_steps_for(rules),
        deterministic=True,
    )  # fmt: skip
    try:
        driver = PathFollower(
            env, line, speeds, closed=track.closed, lookahead=LOOKAHEAD, lookahead_time=LOOKAHEAD_TIME
        )
        result = run_time_trial(env, driver, rules)
    finally:
        env.close()
    laps = result.complete_laps
    if not laps or laps[0].off_track_count or laps[0].time is None:
        return None
    return float(laps[0].time)
