"""The race-pace recipe's reward function, written out as a normal DeepRacer reward file.

The file carries its own racing line (one point per track waypoint, with the speed command the line
asks there), so it runs unchanged in drx, in the DeepRacer console and in deepracer-for-cloud: it reads
only DeepRacer's documented params (``x``, ``y``, ``speed``, ``track_width``, ``closest_waypoints``,
``progress``, ``steps``, ``all_wheels_on_track``, ``is_offtrack``). Embedding the line is what the
community's race-line rewards do (cdthompson's K1999 lines, dgnzlz's ``Capstone_AWS_DeepRacer``
reward with its ``racing_track`` list).

Why the reward has the shape it has (``docs/RACING.md``, "Reward shapes", "Is the last checkpoint
worse?"): a reward paid per step pays a slower lap more, because a slower lap has more steps, and
drx's runs drifted to safer, slower laps under the pursuit reward. Here each step's pay is multiplied
by the car's pace so far against the line's lap (progress per step over the line's), so a lap pays
about the line's steps times how well it was driven, however many steps it took: going slower never
earns more, and the discount pays the faster lap sooner.
"""

from __future__ import annotations

from collections.abc import Sequence

from drx import __version__

TEMPLATE = '''"""Race pace on {track}:
hold drx's racing line at the speed it is driven.

Made by `drx model create --recipe race-pace` (drx {version}) for
the car {car},
on DeepRacer simulator {simulator}'s car.

RACING_LINE is drx's racing line on this track: one point per track
waypoint (point i lies near waypoint i), each with the speed command
[m/s] the line asks for there. The line's lap takes LINE_LAP_STEPS
steps (15 a second).

Each step pays how well the car holds the line (1 on it, 0 half the
road's width off it) plus how near its speed command is to
SPEED_SHARE of the line's (1 at it, 0 SPEED_TOLERANCE away), both
times its pace so far against the line's lap. A lap then pays about
the same however many steps it takes: a slower lap never earns more.
Off the road pays almost nothing.

It reads only DeepRacer's own params, so it runs unchanged in the
DeepRacer console and in deepracer-for-cloud. Change it as any reward
file: `drx reward show MODEL --json` gives this code, and
`drx model clone MODEL NEW --reward your_file.py` trains on with yours.
"""

import math

LINE_LAP_STEPS = {lap_steps}  # the line's lap in 1/15 s steps ({lap_time:.2f} s)
SPEED_TOLERANCE = 1.0  # [m/s] this far from the target earns nothing
SPEED_SHARE = {speed_share}  # target share of the line's speed (grip in reserve)
PACE_CAP = 1.5  # pace above this pays no more (an episode's first steps)
SEARCH = 8  # line points searched either side of the closest waypoint
CLOSED = {closed}  # the track is a loop
# x [m], y [m], speed command [m/s]
RACING_LINE = [
{points}
]


def _nearest(x, y, hint):
    """The index of the line point nearest (x, y), searched around index hint."""
    n = len(RACING_LINE)
    best, best_d2 = hint % n, float("inf")
    for k in range(hint - SEARCH, hint + SEARCH + 1):
        j = k % n if CLOSED else min(max(k, 0), n - 1)
        px, py, _ = RACING_LINE[j]
        d2 = (px - x) ** 2 + (py - y) ** 2
        if d2 < best_d2:
            best, best_d2 = j, d2
    return best


def _segment_distance(x, y, a, b):
    """Distance from (x, y) to the segment between line points a and b."""
    ax, ay, _ = RACING_LINE[a]
    bx, by, _ = RACING_LINE[b]
    dx, dy = bx - ax, by - ay
    length2 = dx * dx + dy * dy
    t = 0.0 if length2 == 0 else max(0.0, min(1.0, ((x - ax) * dx + (y - ay) * dy) / length2))
    return math.hypot(x - (ax + t * dx), y - (ay + t * dy))


def reward_function(params):
    if params["is_offtrack"] or not params["all_wheels_on_track"]:
        return 1e-3
    x, y, speed = params["x"], params["y"], params["speed"]
    n = len(RACING_LINE)
    i = _nearest(x, y, params["closest_waypoints"][1])
    before = (i - 1) % n if CLOSED else max(i - 1, 0)
    after = (i + 1) % n if CLOSED else min(i + 1, n - 1)
    distance = min(_segment_distance(x, y, before, i), _segment_distance(x, y, i, after))
    holding = max(0.0, 1.0 - distance / (0.5 * params["track_width"]))
    matching = max(0.0, 1.0 - abs(speed - SPEED_SHARE * RACING_LINE[i][2]) / SPEED_TOLERANCE)
    pace = (params["progress"] / max(1, params["steps"])) / (100.0 / LINE_LAP_STEPS)
    return float(1e-3 + min(PACE_CAP, pace) * (holding + matching))
'''


def race_pace_reward(
    track: str,
    car: str,
    simulator: str,
    points: Sequence[tuple[float, float, float]],
    lap_time: float,
    closed: bool,
    speed_share: float = 1.0,
) -> str:
    """The reward file's code for one track, direction and car.

    :param track: how the docstring names the track (route id and direction).
    :param car: how the docstring names the car.
    :param simulator: the DeepRacer simulator whose car the line was solved for.
    :param points: ``(x, y, speed command)`` per track waypoint, in driving order, no closing duplicate.
    :param lap_time: [s] the line's lap.
    :param closed: whether the track is a loop.
    :param speed_share: the reward's target speed as a share of the line's speed command.
    """
    rows = "\n".join(f"    ({x:.4f}, {y:.4f}, {v:.2f})," for x, y, v in points)
    return TEMPLATE.format(
        track=track,
        version=__version__,
        car=car,
        simulator=simulator,
        lap_steps=max(1, round(lap_time * 15.0)),
        lap_time=lap_time,
        closed=bool(closed),
        speed_share=f"{speed_share:g}",
        points=rows,
    )
