"""Bot cars for head-to-bot races: they drive the track's lanes on lane coordinates.

Placement and lane changes follow DeepRacer's simulator (``BotCarsCtrl``): the
bots start evenly spread from 2 m ahead of the car to 1 m behind it, alternating
lanes from the inside (random places at least 2 m apart and random lanes when
randomised); with lane changes on, each bot switches to the other lane every
3-5 s (uniform), moving across over 1 m of track along a smooth curve. Like
DeepRacer's bots they ignore the agent car: avoiding them is the agent's job.

Among themselves the bots use highway-env's behaviour models
(:class:`highway_env.vehicle.behavior.IDMVehicle`): the Intelligent Driver Model
for speed and gap to the bot ahead in the lane, and MOBIL's safety criterion
for a lane change (the new follower must not have to brake harder than
``LANE_CHANGE_MAX_BRAKING_IMPOSED``). drx evaluates those equations, with
``IDMVehicle``'s constants, on its own lane coordinate (distance along the
centre line, lane -1..+1) instead of calling ``IDMVehicle`` itself: that class
needs highway-env's ``Road``/``Lane`` objects, which cannot follow a
DeepRacer route, and NumPy vectors per call (tens of microseconds per bot per
step). Two adaptations, both documented here:

* scale: highway-env's cars are 5 m long; distances are scaled by
  ``BOT_LENGTH / IDMVehicle.LENGTH`` and times by its square root (Froude
  scaling keeps accelerations, so the comfortable accelerations stay as they
  are): a 0.64 m jam distance and a 0.38 s time gap;
* IDM+ (Schakel et al., 2010) combines the free-road and interaction terms by a
  minimum instead of a sum, so a bot with a distant bot ahead keeps exactly its
  set speed, as DeepRacer's bots do, and only brakes when it closes in.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from drx.settings.race import RaceConfig

if TYPE_CHECKING:
    from drx.sim.objects import LaneFrame, SceneObject

BOT_SIZE = (0.32, 0.20, 0.15)  # [m] length, width, height (DeepRacer's bot car: 0.32 x 0.20)
FIRST_BOT_AHEAD = 2.0  # [m] DeepRacer's MIN_DISTANCE_BETWEEN_BOT_CARS: first bot ahead of the start
LAST_BOT_BEHIND = 1.0  # [m] the last bot this far behind the start (DeepRacer: track length - 1 m)
LANE_CHANGE_TIME = (3.0, 5.0)  # [s] between lane changes (DeepRacer's lower/upper bounds)
LANE_CHANGE_DISTANCE = 1.0  # [m] of track a lane change takes


def _idm_constants() -> dict[str, float]:
    """highway-env's IDM/MOBIL constants, scaled from a 5 m car to a bot car (see the module doc)."""
    from highway_env.vehicle.behavior import IDMVehicle

    scale = BOT_SIZE[0] / IDMVehicle.LENGTH
    return {
        "acc_max": float(IDMVehicle.COMFORT_ACC_MAX),  # [m/s^2]
        "acc_min": float(IDMVehicle.COMFORT_ACC_MIN),  # [m/s^2], negative
        "delta": float(IDMVehicle.DELTA),
        "distance_wanted": float(IDMVehicle.DISTANCE_WANTED) * scale,  # [m]
        "time_wanted": float(IDMVehicle.TIME_WANTED) * math.sqrt(scale),  # [s]
        "max_braking_imposed": float(IDMVehicle.LANE_CHANGE_MAX_BRAKING_IMPOSED),  # [m/s^2]
    }


class Bot:
    """One bot car's state on lane coordinates.

    :param s: distance along the centre line from the start line [m], unwrapped.
    :param lane: the lane it drives or is changing to, +1 left / -1 right.
    """

    __slots__ = ("s", "lane", "lateral", "speed", "change_from", "change_s0", "next_change", "obj")

    def __init__(self, s: float, lane: float, speed: float, obj: SceneObject) -> None:
        self.s, self.lane, self.lateral, self.speed = s, lane, lane, speed
        self.change_from: float | None = None  # lane coordinate at the start of a lane change
        self.change_s0 = 0.0
        self.next_change = math.inf
        self.obj = obj

    @property
    def changing(self) -> bool:
        """Whether a lane change is under way."""
        return self.change_from is not None

    def occupies(self, lane: float) -> bool:
        """Whether the bot takes up ``lane`` (both lanes while it changes)."""
        return self.lane == lane or self.change_from == lane


class BotTraffic:
    """The bots of a head-to-bot race.

    :param frame: lane coordinates of the track (driving direction).
    :param race: the race settings (``bots``, ``bot_speed``, ``bot_lane_change``).
    """

    def __init__(self, frame: LaneFrame, race: RaceConfig) -> None:
        self.frame, self.race = frame, race
        self.speed = race.bot_speed_mps
        self.k = _idm_constants()
        k = self.k
        # (a, delta, s0, T, 2 sqrt(a b)) for the per-step IDM
        self._idm = (k["acc_max"], k["delta"], k["distance_wanted"], k["time_wanted"],
                     2.0 * math.sqrt(-k["acc_max"] * k["acc_min"]))  # fmt: skip
        self.bots: list[Bot] = []
        self.time = 0.0
        self._rng = np.random.default_rng(0)

    # ----- set-up ---------------------------------------------------------------------------------
    def reset(self, rng: np.random.Generator, start_s: float, randomize: bool) -> list[SceneObject]:
        """Place the bots for an episode starting at ``start_s`` [m]; returns their scene objects."""
        from drx.sim.objects import SceneObject

        n, length = self.race.bot_count, self.frame.length
        lo, hi = FIRST_BOT_AHEAD, max(length - LAST_BOT_BEHIND, FIRST_BOT_AHEAD)
        if not self.frame.closed:
            hi = max(min(hi, length - start_s - 0.5), lo)
        dists = np.linspace(lo, hi, n) if n > 1 else np.array([lo])
        inside = [self.frame.lane_of("inside", start_s + float(d)) for d in dists]
        lanes = [inside[i] if i % 2 == 0 else -inside[i] for i in range(n)]
        if randomize:
            for i in rng.permutation(n):  # DeepRacer's perturbation of the even spread
                a = lo if i == 0 else dists[i - 1] + FIRST_BOT_AHEAD
                b = hi if i == n - 1 else dists[i + 1] - FIRST_BOT_AHEAD
                if a < b:
                    dists[i] = rng.uniform(a, b)
            inside = [self.frame.lane_of("inside", start_s + float(d)) for d in dists]
            lanes = [float(rng.choice((side, -side))) for side in inside]
        self._rng = rng
        self.time = 0.0
        self.bots = []
        for d, lane in zip(dists, lanes, strict=True):
            bot = Bot(start_s + float(d), lane, self.speed, SceneObject("bot", BOT_SIZE, BOT_SIZE[:2]))
            if self.race.bot_lane_change:
                bot.next_change = float(rng.uniform(*LANE_CHANGE_TIME))
            self.bots.append(bot)
        self._place_all()
        return [b.obj for b in self.bots]

    # ----- one step -------------------------------------------------------------------------------
    def step(self, dt: float) -> None:
        """Advance every bot by ``dt`` [s]: IDM speed, then position, then lane changes."""
        self.time += dt
        bots = self.bots
        accels = [self._accel(b, self._leader(b, b.lane)) for b in bots]
        top, end = self.speed, self.frame.length
        for bot, acc in zip(bots, accels, strict=True):
            v = bot.speed + acc * dt
            bot.speed = v = 0.0 if v < 0.0 else (top if v > top else v)
            bot.s += v * dt
        if not self.frame.closed:
            for bot in bots:
                if bot.s > end:
                    bot.s, bot.speed = end, 0.0  # an open track's end: the bot parks
        if self.race.bot_lane_change:
            for bot in bots:
                self._lane_change(bot)
        self._place_all()

    def _gap(self, rear: Bot, front: Bot) -> float:
        """Bumper-to-bumper distance [m] from ``rear`` forward to ``front`` along the lap."""
        d = front.s - rear.s
        if self.frame.closed:
            d %= self.frame.length
        return d - BOT_SIZE[0]

    def _nearest(self, bot: Bot, lane: float, sign: float) -> Bot | None:
        """The nearest other bot taking up ``lane``, ahead (``sign`` +1) or behind (-1)."""
        best, best_d = None, math.inf
        length, closed = self.frame.length, self.frame.closed
        for other in self.bots:
            if other is bot or (other.lane != lane and other.change_from != lane):
                continue
            d = sign * (other.s - bot.s)
            if closed:
                d %= length
            elif d < 0:
                continue
            if d < best_d:
                best, best_d = other, d
        return best

    def _leader(self, bot: Bot, lane: float) -> Bot | None:
        """The nearest other bot ahead taking up ``lane``."""
        return self._nearest(bot, lane, 1.0)

    def _follower(self, bot: Bot, lane: float) -> Bot | None:
        """The nearest other bot behind taking up ``lane``."""
        return self._nearest(bot, lane, -1.0)

    def _accel(self, bot: Bot | None, front: Bot | None) -> float:
        """IDM+ acceleration [m/s^2] of ``bot`` behind ``front`` (highway-env's IDM terms)."""
        if bot is None:
            return 0.0
        acc_max, delta, jam, headway, comfort = self._idm
        v = bot.speed if bot.speed > 0.0 else 0.0
        free = 1.0 - (v / self.speed) ** delta
        if front is None:
            return acc_max * free
        gap = self._gap(bot, front)
        gap = gap if gap > 1e-3 else 1e-3
        wanted = jam + v * headway + v * (v - front.speed) / comfort
        wanted = wanted if wanted > 0.0 else 0.0
        interaction = 1.0 - (wanted / gap) ** 2
        return acc_max * (free if free < interaction else interaction)

    def _lane_change(self, bot: Bot) -> None:
        """Start, go on with or finish a lane change (DeepRacer's timer, MOBIL's safety check)."""
        start = bot.change_from
        if start is not None:  # changing lanes
            done = (bot.s - bot.change_s0) / LANE_CHANGE_DISTANCE
            if done >= 1.0:
                bot.change_from, bot.lateral = None, bot.lane
                bot.next_change = self.time + float(self._rng.uniform(*LANE_CHANGE_TIME))
            else:
                u = done * done * (3.0 - 2.0 * done)  # smoothstep: no lateral jump at either end
                bot.lateral = start + (bot.lane - start) * u
            return
        if self.time < bot.next_change:
            return
        target = -bot.lane
        follower = self._follower(bot, target)
        leader = self._leader(bot, target)
        braking = self.k["max_braking_imposed"]
        safe = (follower is None or self._accel(follower, bot) >= -braking) and (
            leader is None or self._accel(bot, leader) >= -braking
        )
        if (
            safe
            and (leader is None or self._gap(bot, leader) > 0.0)
            and (follower is None or self._gap(follower, bot) > 0.0)
        ):
            bot.change_from, bot.lane, bot.change_s0 = bot.lane, target, bot.s
        # unsafe: try again next step

    def _place_all(self) -> None:
        """Move every bot's scene object to its lane coordinates (heading turned while it changes lane)."""
        frame = self.frame
        for bot in self.bots:
            s = frame.wrap(bot.s)
            lane_width = 0.5 * frame.track.width_at(s)  # a lane is half the road
            offset = 0.5 * lane_width * bot.lateral
            slope = 0.0
            if bot.change_from is not None:  # the heading follows the lateral motion
                across = 0.5 * lane_width * (bot.lane - bot.change_from)
                p = min(max((bot.s - bot.change_s0) / LANE_CHANGE_DISTANCE, 0.0), 1.0)
                slope = math.atan(across * 6.0 * p * (1.0 - p) / LANE_CHANGE_DISTANCE)
            bot.obj.place(frame, s, offset, slope)
            bot.obj.speed = bot.speed
