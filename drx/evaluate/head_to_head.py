"""Head-to-head: two to four models race on one track at once, under DeepRacer's multi-car rules.

Each car is a ``drx/DeepRacer-v0`` env of its own, driven by its own policy through its own
sensors; the other cars are objects in its scene (:class:`drx.sim.race_cars.OtherCars`): its
camera and lidar see them, its ``params`` list them and its crash test hits them. All the envs
share one clock (one noisy step length per step, as DeepRacer's agents share one Gazebo world),
so they move in lockstep. The rules are deepracer-simapp's, each with its name there:

* **Start lanes** (``bundle/markov/agent_ctrl/rollout_agent_ctrl.py``, ``RolloutCtrl.__init__``,
  ``_start_lane_``): agent ``racecar_i`` starts on the inner lane when ``i`` is odd, on the outer
  lane when even (halfway between the centre line and that border).
* **Stagger** (``bundle/markov/track_geom/utils.py`` ``get_start_positions``, offset
  ``START_POS_OFFSET`` = 0.75 m from ``bundle/markov/track_geom/constants.py``, clamped to 0-1 m by
  ``bundle/markov/evaluation_worker.py``): ``racecar_i`` starts ``i * offset`` metres behind the start
  line, and its progress counts from the line (its first lap is that much longer:
  ``_start_line_ndist_offset``).
* **Continuous laps**: a car drives on over the line (the worker's ``is_continuous``); each lap is
  one episode of its trace.
* **Penalties** (``RolloutCtrl._penalties``): seconds the car stands (``pause``), per status:
  ``OFF_TRACK_PENALTY``, ``COLLISION_PENALTY``, ``REVERSE_PENALTY`` (default the off-track's),
  ``IMMOBILIZED_PENALTY`` (default 0). After an off-track, reversed or immobilized ending the car
  is put back at the previous step's progress on the nearer lane, then stands; after a crash
  into another car it stands where it is (``_judge_action_at_run_phase``). While it stands it is
  seen but cannot be hit (DeepRacer takes it out of the collision list while it blinks).
* **Who a crash costs** (``_check_for_episode_termination``): both cars touch, but only the one
  behind (less race progress) is penalised; the car ahead drives on (``in_progress``). drx counts
  the contact for both (``collisions``) and the penalised ones apart (``crashes``).
* **The end** (``DONE_CONDITION``, ``any`` by default, read by ``evaluation_worker.py``'s
  ``str_to_done_condition``): ``any`` ends the race when the first car completes its laps;
  ``all`` when every car has (a finished car parks off the track). The time cap ends it too.

Places: finished cars by their finishing time, then the others by race distance (laps and
progress). A car's time is the race clock when it finished: its pauses (penalties) are in it.
:func:`run_head_to_head` stores nothing.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from drx.errors import SettingError
from drx.evaluate.time_trial import LAPS_RANGE, Policy
from drx.sim.episode_status import EpisodeStatus

CARS_RANGE = (2, 4)
DONE_CONDITIONS = ("any", "all")
START_POS_OFFSET = 0.75  # [m] DeepRacer's default stagger between consecutive cars
START_POS_OFFSET_RANGE = (0.0, 1.0)  # [m] evaluation_worker.py clamps START_POS_OFFSET so
PENALISED = (EpisodeStatus.OFF_TRACK, EpisodeStatus.REVERSED, EpisodeStatus.IMMOBILIZED)


@dataclass(frozen=True)
class HeadToHeadRules:
    """The rules of a head-to-head race (DeepRacer's names in brackets).

    :param laps: laps each car drives, 1-100 (``NUMBER_OF_TRIALS`` of a continuous race).
    :param off_track_penalty: [s] stood after leaving the road (``OFF_TRACK_PENALTY``, 2).
    :param collision_penalty: [s] stood by the car behind after a collision (``COLLISION_PENALTY``, 5).
    :param reverse_penalty: [s] after driving the wrong way (``REVERSE_PENALTY``); ``None``: the
        off-track penalty, as simapp defaults it.
    :param immobilized_penalty: [s] after standing still (``IMMOBILIZED_PENALTY``, 0).
    :param done_condition: ``any`` (the race ends when one car finishes) or ``all`` (``DONE_CONDITION``).
    :param start_position_offset: [m] between consecutive cars at the start, 0-1 (``START_POS_OFFSET``).
    :param time_cap_minutes: the race ends at this race time, > 0.
    :param direction: ``default`` (the track's own) or ``reverse``.
    """

    laps: int = 3
    off_track_penalty: float = 2.0
    collision_penalty: float = 5.0
    reverse_penalty: float | None = None
    immobilized_penalty: float = 0.0
    done_condition: str = "any"
    start_position_offset: float = START_POS_OFFSET
    time_cap_minutes: float = 20.0
    direction: str = "default"

    def __post_init__(self) -> None:
        lo, hi = LAPS_RANGE
        if isinstance(self.laps, bool) or not isinstance(self.laps, int) or not lo <= self.laps <= hi:
            raise SettingError("{field} {value} is out of range; use {lo} to {hi}.", "laps",
                               value=self.laps, lo=lo, hi=hi)  # fmt: skip
        for name in ("off_track_penalty", "collision_penalty", "reverse_penalty", "immobilized_penalty"):
            value = getattr(self, name)
            if value is not None and not (math.isfinite(value) and value >= 0):
                raise SettingError("{field} {value:g} is invalid; use 0 or more seconds.", name, value=value)
        if self.done_condition not in DONE_CONDITIONS:
            raise SettingError("{field} {value!r} is unknown; use any or all.", "done_condition",
                               value=self.done_condition)  # fmt: skip
        lo_m, hi_m = START_POS_OFFSET_RANGE
        if not (math.isfinite(self.start_position_offset) and lo_m <= self.start_position_offset <= hi_m):
            raise SettingError("{field} {value:g} is out of range; use {lo:g} to {hi:g} metres.",
                               "start_position_offset", value=self.start_position_offset,
                               lo=lo_m, hi=hi_m)  # fmt: skip
        if not (math.isfinite(self.time_cap_minutes) and 0 < self.time_cap_minutes <= 24 * 60):
            raise SettingError("{field} {value:g} is invalid; use more than 0, up to 1440.",
                               "time_cap_minutes", value=self.time_cap_minutes)  # fmt: skip

    def penalty(self, status: str) -> float:
        """[s] the pause a status costs (simapp's ``_penalties``)."""
        if status == EpisodeStatus.OFF_TRACK:
            return self.off_track_penalty
        if status == EpisodeStatus.REVERSED:
            return self.off_track_penalty if self.reverse_penalty is None else self.reverse_penalty
        if status == EpisodeStatus.IMMOBILIZED:
            return self.immobilized_penalty
        if status == EpisodeStatus.CRASHED:
            return self.collision_penalty
        return 0.0

    def to_dict(self) -> dict[str, Any]:
        """The rules as stored with a race (``race_type`` ``head_to_head``)."""
        return {"race_type": "head_to_head", **asdict(self)}


@dataclass
class CarResult:
    """One car's race.

    :param index: its place in the start order (``racecar_<index>``).
    :param name: the model's name.
    :param place: 1-based finishing place.
    :param status: ``finished``, or ``racing`` when the race ended before it finished.
    :param lap_times: [s] each complete lap, pauses included.
    :param time: [s] the race clock when it finished (pauses included); ``None`` unfinished.
    :param progress: [%] of the lap it was on when the race ended (100 when finished).
    :param collisions: contacts with another car (both cars count one).
    :param crashes: collisions it was penalised for (it was behind).
    :param off_tracks: times it left the road.
    :param reversed: times it drove the wrong way 15 steps in a row.
    :param immobilized: times it stood still.
    :param penalty_seconds: [s] it stood for penalties.
    :param steps: steps it drove.
    """

    index: int
    name: str
    place: int = 0
    status: str = "racing"
    lap_times: list[float] = field(default_factory=list)
    time: float | None = None
    progress: float = 0.0
    collisions: int = 0
    crashes: int = 0
    off_tracks: int = 0
    reversed: int = 0
    immobilized: int = 0
    penalty_seconds: float = 0.0
    steps: int = 0

    @property
    def laps(self) -> int:
        """Complete laps."""
        return len(self.lap_times)

    def to_dict(self) -> dict[str, Any]:
        """A JSON-friendly dict."""
        d = asdict(self)
        d["laps"] = self.laps
        d["lap_times"] = [round(t, 4) for t in self.lap_times]
        d["time"] = None if self.time is None else round(self.time, 4)
        d["progress"] = round(self.progress, 2)
        d["penalty_seconds"] = round(self.penalty_seconds, 4)
        return d


@dataclass
class RaceResult:
    """The outcome of a head-to-head race.

    :param rules: the rules it ran under.
    :param cars: every car, in finishing order.
    :param ended: ``any_finished``, ``all_finished`` or ``time_cap``.
    :param race_time: [s] the race clock at the end.
    :param seed: the seed of the shared clock's noise.
    """

    rules: HeadToHeadRules
    cars: list[CarResult]
    ended: str = "running"
    race_time: float = 0.0
    seed: int = 0

    @property
    def winner(self) -> CarResult:
        """The car in first place."""
        return self.cars[0]

    def to_dict(self) -> dict[str, Any]:
        """A JSON-friendly summary."""
        return {
            "rules": self.rules.to_dict(),
            "ended": self.ended,
            "race_time": round(self.race_time, 4),
            "seed": self.seed,
            "cars": [c.to_dict() for c in self.cars],
        }


@dataclass(frozen=True)
class CarView:
    """One car after a step, for the video and the observer.

    :param index: start order.
    :param x: rear-axle x [m].
    :param y: rear-axle y [m].
    :param yaw: [rad].
    :param speed: [m/s].
    :param status: its env's status this step, or ``pause`` / ``parked`` / ``finished``.
    :param event: ``""`` or what happened this step (``off_track``, ``crashed``, ``collision``,
        ``lap_complete``, ``finished``, ...).
    :param observation: its camera observation.
    :param result: its result so far.
    """

    index: int
    x: float
    y: float
    yaw: float
    speed: float
    status: str
    event: str
    observation: Any
    result: CarResult


@dataclass(frozen=True)
class RaceView:
    """Every car after a step."""

    race_time: float
    cars: tuple[CarView, ...]


RaceObserver = Callable[[RaceView], None]


class SharedClock:
    """One step length per step for every car of a race (the env's ``clock``).

    :param noise: the draws (a :class:`drx.sim.noise.StepNoise`); :meth:`tick` takes the next one.
    """

    def __init__(self, noise: Any) -> None:
        self._noise = noise
        self.dt = noise.nominal

    def tick(self) -> float:
        """Draw the length of the next step [s]."""
        self.dt = float(self._noise.step_time())
        return self.dt

    def step_time(self) -> float:
        """This step's length [s] (the same for every car)."""
        return self.dt

    def reseed(self, rng: np.random.Generator) -> None:
        """Nothing: the race seeds the clock, not a car's reset."""


@dataclass
class _Car:
    """A car's race state (the loop's bookkeeping)."""

    env: Any
    base: Any
    policy: Policy
    result: CarResult
    obs: Any = None
    pause: float = 0.0  # [s] left to stand
    lap_start: float = 0.0  # [s] the race clock when its lap started
    finished: bool = False
    parked: bool = False
    status: str = EpisodeStatus.PREPARE
    event: str = ""
    hit: int | None = None  # the other car it hit this step (its index in the race)


def start_places(n: int, offset: float, length: float) -> list[tuple[float, str]]:
    """Where each car starts: ``(fraction of the lap, lane)``, ``racecar_0`` on the line.

    ``racecar_i`` is ``i * offset`` metres behind the line (``get_start_positions``) on the inner lane
    when ``i`` is odd, the outer when even (``_start_lane_``).
    """
    return [((-offset * i / length) % 1.0, "inside" if i % 2 else "outside") for i in range(n)]


def run_head_to_head(
    envs: Sequence[Any],
    policies: Sequence[Policy],
    names: Sequence[str],
    rules: HeadToHeadRules,
    clock: SharedClock,
    seed: int = 0,
    observer: RaceObserver | None = None,
) -> RaceResult:
    """Race the cars of ``envs`` (each made with ``clock`` and an :class:`OtherCars` scene).

    :param envs: one ``drx/DeepRacer-v0`` env per car (or a wrapper: a trace writer), in start order,
        ``mode="evaluation"``, on the same track, their ``scene`` the other cars.
    :param policies: ``observation -> action`` per car.
    :param names: the cars' names (the models').
    :param rules: the race's rules.
    :param clock: the clock every env was made with.
    :param seed: seeds every env (and so nothing else: the clock's noise is seeded by its maker).
    :param observer: called after the start and every step with a :class:`RaceView`.
    :return: the result, cars in finishing order; nothing is stored.
    """
    from drx.sim.objects import LaneFrame

    if not CARS_RANGE[0] <= len(envs) <= CARS_RANGE[1]:
        raise SettingError("A race takes {lo} to {hi} cars, not {n}.", "models",
                           lo=CARS_RANGE[0], hi=CARS_RANGE[1], n=len(envs))  # fmt: skip
    cars = [
        _Car(env, getattr(env, "unwrapped", env), policy, CarResult(i, name))
        for i, (env, policy, name) in enumerate(zip(envs, policies, names, strict=True))
    ]
    track = cars[0].base.track
    frame = LaneFrame(track)
    for i, (car, (frac, lane)) in enumerate(
        zip(cars, start_places(len(cars), rules.start_position_offset, track.length), strict=True)
    ):
        s = frac * track.length
        offset = frame.lane_offset(s, frame.lane_of(lane, s))
        car.obs, _ = car.env.reset(seed=seed + i, options={"start": frac, "lane": offset, "line": 0.0})
    cap = rules.time_cap_minutes * 60.0
    clock_time = 0.0
    _place_others(cars, frame)
    for car in cars:  # the first observation, with the others on the grid (at rest, where it stands)
        car.obs, _ = car.env.reset(options={"resume": True, "in_place": True})
    _notify(observer, cars, clock_time)
    ended = "time_cap"
    while clock_time < cap:
        dt = clock.tick()
        clock_time += dt
        for car in cars:
            car.event, car.hit = "", None
            if car.finished:
                continue
            if car.pause > 0.0:
                car.pause -= dt
                car.status = EpisodeStatus.PAUSE
                continue
            car.obs, _r, _t, _tr, info = car.env.step(car.policy(car.obs))
            car.result.steps += 1
            car.status = str(info.get("episode_status", EpisodeStatus.IN_PROGRESS))
            crash = info.get("crash")
            if crash is not None:
                car.hit = _race_index(car.result.index, int(crash["index"]))
            car.result.progress = float(info.get("progress", 0.0))
        _collisions(cars, rules)
        for car in cars:
            if not car.finished and car.pause <= 0.0 and car.event == "":
                _judge(car, rules, clock_time)
        if _done(cars, rules):
            ended = "any_finished" if rules.done_condition == "any" else "all_finished"
            _place_others(cars, frame)
            _notify(observer, cars, clock_time)
            break
        _place_others(cars, frame)
        _notify(observer, cars, clock_time)
    return RaceResult(rules=rules, cars=_ranked(cars), ended=ended, race_time=clock_time, seed=seed)


def _race_index(me: int, other: int) -> int:
    """The race index of the ``other``-th car in car ``me``'s scene (its list skips ``me``)."""
    return other if other < me else other + 1


def _collisions(cars: list[_Car], rules: HeadToHeadRules) -> None:
    """Judge this step's collisions: both cars count one; the one behind stands the penalty."""
    pairs = {tuple(sorted((car.result.index, car.hit))) for car in cars if car.hit is not None}
    behind_ones: set[int] = set()
    for a, b in sorted(pairs):
        ca, cb = cars[a], cars[b]
        ca.result.collisions += 1
        cb.result.collisions += 1
        da, db = _race_distance(ca), _race_distance(cb)
        if da != db:  # simapp: the car with less progress is at fault; equal progress: neither
            behind_ones.add(a if da < db else b)
        for car in (ca, cb):
            car.event = "collision"
    for i in sorted(behind_ones):
        car = cars[i]
        penalty = rules.collision_penalty
        car.result.crashes += 1
        car.result.penalty_seconds += penalty
        car.obs, _ = car.env.reset(options={"resume": True, "in_place": True, "pause": penalty})
        car.pause = penalty
        car.event = EpisodeStatus.CRASHED
    for car in cars:  # the car ahead drives on: a crash status it saw is no ending for it
        if car.event == "collision" and car.status == EpisodeStatus.CRASHED:
            car.status = EpisodeStatus.IN_PROGRESS
            car.event = ""


def _race_distance(car: _Car) -> float:
    """[m] the car's race distance: complete laps and this lap's distance from the line."""
    return car.result.laps * car.base.track.length + float(car.base.distance)


def _judge(car: _Car, rules: HeadToHeadRules, clock_time: float) -> None:
    """What the car's step ended with: a lap, the race, or a penalised reset."""
    status = car.status
    if status == EpisodeStatus.LAP_COMPLETE:
        car.result.lap_times.append(clock_time - car.lap_start)
        car.lap_start = clock_time
        car.event = EpisodeStatus.LAP_COMPLETE
        if car.result.laps >= rules.laps:
            car.finished, car.result.status, car.result.time = True, "finished", clock_time
            car.result.progress = 100.0
            car.parked = rules.done_condition == "all"  # it leaves the track for the others
            car.event = "finished"
            return
        car.obs, _ = car.env.reset(options={"next_lap": True})
        return
    if status in PENALISED:
        if status == EpisodeStatus.OFF_TRACK:
            car.result.off_tracks += 1
        elif status == EpisodeStatus.REVERSED:
            car.result.reversed += 1
        else:
            car.result.immobilized += 1
        penalty = rules.penalty(status)
        car.result.penalty_seconds += penalty
        car.obs, _ = car.env.reset(options={"resume": True, "pause": penalty})
        car.pause = penalty
        car.event = status
    elif status == EpisodeStatus.TIME_UP:  # the env's own step limit: it stands from now on
        car.finished = True


def _done(cars: list[_Car], rules: HeadToHeadRules) -> bool:
    """Whether DONE_CONDITION holds: any car (``any``) or every car (``all``) finished."""
    done = [car.result.status == "finished" for car in cars]
    return any(done) if rules.done_condition == "any" else all(done)


def _place_others(cars: list[_Car], frame: Any) -> None:
    """Move every car's view of the others to where they are now."""
    for me in cars:
        scene = me.base.scene
        for other in cars:
            if other is me:
                continue
            st = other.base.car_state
            k = other.result.index if other.result.index < me.result.index else other.result.index - 1
            s = frame.wrap(other.base.track.project(st.x, st.y).s)
            scene.move(k, st.x, st.y, st.yaw, st.speed, s, ghost=other.pause > 0.0, parked=other.parked)
        scene.refresh()


def _ranked(cars: list[_Car]) -> list[CarResult]:
    """Finishing order: finished cars by time, then the rest by race distance."""

    def key(car: _Car) -> tuple[float, float]:
        if car.result.time is not None:
            return (0.0, car.result.time)
        return (1.0, -_race_distance(car))

    ordered = sorted(cars, key=key)
    for place, car in enumerate(ordered, start=1):
        car.result.place = place
    return [car.result for car in ordered]


def _notify(observer: RaceObserver | None, cars: list[_Car], clock_time: float) -> None:
    if observer is None:
        return
    views = []
    for car in cars:
        st = car.base.car_state
        status = "parked" if car.parked else ("pause" if car.pause > 0.0 else str(car.status))
        views.append(CarView(car.result.index, float(st.x), float(st.y), float(st.yaw), float(st.speed),
                             status, car.event, car.obs, car.result))  # fmt: skip
    observer(RaceView(clock_time, tuple(views)))
