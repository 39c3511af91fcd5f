"""The evaluation rules engine: DeepRacer's evaluation race, run in drx's simulator.

Rules (``../shared/DEEPRACER.md`` sections 4-5):

* The car starts at rest on the start line and drives ``laps`` laps. The
  policy is any callable ``observation -> action``; for a trained model it is
  the most probable action (see :mod:`drx.evaluate.policy`).
* A lap's time is its simulated time (the sum of its steps' lengths, which
  vary as DeepRacer's do unless the env is ``deterministic``) plus its
  penalties.
* **Off track** (no wheel on the road) and **reversed** (15 steps going the
  wrong way): the lap gets ``off_track_penalty`` seconds (DeepRacer charges a
  reversed ending the off-track penalty unless told otherwise: deepracer-simapp
  ``markov/agent_ctrl/rollout_agent_ctrl.py``, ``REVERSE_PENALTY`` defaults to
  ``OFF_TRACK_PENALTY``): the car stands for that time, then restarts at rest at
  the previous step's progress on the nearer lane (the env's
  ``reset(options={"resume": True, "pause": seconds})``), and the lap goes on;
  that is one *reset*.
* **Crash** (object avoidance and head-to-bot: the car hit a box or a bot):
  the lap gets ``collision_penalty`` seconds (DeepRacer: 5 s) and counts the
  crash; the env puts the car at rest on the centre line 0.5 m behind the
  object (``reset(options={"resume": True})``) and the lap goes on; a reset.
* **Immobilized**: the car is put back the same way, a reset without a
  penalty (``IMMOBILIZED_PENALTY`` defaults to 0).
* The trial ends after the laps, when the total time (simulated time plus
  penalties) reaches ``time_cap_minutes``, or when the car needs a reset
  after ``max_resets`` resets already (``None``: no limit). The lap that was
  running then ends with status ``time_up`` or ``off_track``, its progress
  kept, no time.
* Every lap starts from rest at the start line, as in DeepRacer's
  evaluations (the console's evaluation trace in ``shared/deepracer-logs``
  shows each lap as a new episode whose first row is ``prepare`` at the start
  line). A lap completes on the first step past the line, so each lap
  boundary is exact to one step. On an open track a lap ends at the far end.

:func:`run_time_trial` drives an env and returns a :class:`TrialResult`; it
stores nothing. A :class:`StepView` per step goes to an optional observer
(the video writer).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any

from drx.errors import DrxError, SettingError
from drx.settings.race import TIME_TRIAL, RaceConfig
from drx.sim.episode_status import EpisodeStatus

STEP_RATE = 15.0  # [Hz] DeepRacer's step rate; the env's CarParams.rate_hz is used when present
LAPS_RANGE = (1, 100)
DEFAULT_PENALTY = 2.0  # [s] the console's off-track penalty
DEFAULT_COLLISION_PENALTY = 5.0  # [s] DeepRacer's collision penalty
DEFAULT_TIME_CAP = 20.0  # [min]
# The env's endings after which an evaluation puts the car back and the lap goes on.
RESET_STATUSES = (
    EpisodeStatus.OFF_TRACK,
    EpisodeStatus.IMMOBILIZED,
    EpisodeStatus.REVERSED,
    EpisodeStatus.CRASHED,
)
PENALISED_RESETS = (EpisodeStatus.OFF_TRACK, EpisodeStatus.REVERSED)  # charged the off-track penalty

Policy = Callable[[Any], Any]


@dataclass(frozen=True)
class RaceRules:
    """The settings of an evaluation race.

    :param laps: laps to drive, 1-100.
    :param off_track_penalty: seconds added to the lap for each off-track or reversed ending, >= 0.
    :param max_resets: the most times the car is put back on the track; ``None`` for no limit.
    :param time_cap_minutes: the trial stops when its total time reaches this, > 0.
    :param direction: ``"default"`` (the track's own direction) or ``"reverse"``.
    :param collision_penalty: seconds added to the lap for each crash into a box or bot, >= 0.
    :param race: the race type with its boxes or bots (:class:`~drx.settings.race.RaceConfig`).
    :param min_laps: complete laps in a row a result needs to qualify for the leaderboard, 1 to
        ``laps`` (DeepRacer on AWS's ``minimumLaps``); ``None`` (or 0): every result qualifies. The
        trial drives its ``laps`` either way: the minimum judges the result, it ends nothing.
    """

    laps: int = 3
    off_track_penalty: float = DEFAULT_PENALTY
    max_resets: int | None = None
    time_cap_minutes: float = DEFAULT_TIME_CAP
    direction: str = "default"
    collision_penalty: float = DEFAULT_COLLISION_PENALTY
    race: RaceConfig = TIME_TRIAL
    min_laps: int | None = None

    def __post_init__(self) -> None:
        lo, hi = LAPS_RANGE
        if not (isinstance(self.laps, int) and lo <= self.laps <= hi):
            raise SettingError(
                "{field} {value} is out of range; use {lo} to {hi}.", "laps", value=self.laps, lo=lo, hi=hi
            )
        if not (math.isfinite(self.off_track_penalty) and self.off_track_penalty >= 0):
            raise SettingError(
                "{field} {value:g} is invalid; use 0 or more seconds.",
                "off_track_penalty",
                value=self.off_track_penalty,
            )
        if self.max_resets is not None and self.max_resets < 0:
            raise SettingError(
                "{field} {value} is invalid; use 0 or more.", "max_resets", value=self.max_resets
            )
        if not (math.isfinite(self.time_cap_minutes) and 0 < self.time_cap_minutes <= 24 * 60):
            raise SettingError(
                "{field} {value:g} is invalid; use more than 0, up to 1440.",
                "time_cap_minutes",
                value=self.time_cap_minutes,
            )
        if self.direction not in ("default", "reverse"):
            raise DrxError(f"direction {self.direction!r} is unknown; use 'default' or 'reverse'.")
        if not (math.isfinite(self.collision_penalty) and self.collision_penalty >= 0):
            raise SettingError(
                "{field} {value:g} is invalid; use 0 or more seconds.",
                "collision_penalty",
                value=self.collision_penalty,
            )
        if not isinstance(self.race, RaceConfig):
            object.__setattr__(self, "race", RaceConfig.from_dict(self.race))
        self._check_min_laps()

    def _check_min_laps(self) -> None:
        """``min_laps`` is a whole number from 0 to ``laps``; 0 is stored as ``None`` (no minimum), so
        the two spellings are one rule set on the leaderboard."""
        value = self.min_laps
        if value is None:
            return
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise SettingError(
                "{field} {value} is invalid; use a whole number from 1 to {count} (the race's {laps}), "
                "or leave it out for no minimum.",
                "min_laps",
                "laps",
                value=value,
                count=self.laps,
            )
        if value > self.laps:
            raise SettingError(
                "{field} {value} is more than the race's {laps} {count}; use {field} {count} or fewer, "
                "or race more laps with {laps} {value}.",
                "min_laps",
                "laps",
                value=value,
                count=self.laps,
            )
        if value == 0:
            object.__setattr__(self, "min_laps", None)

    @property
    def race_type(self) -> str:
        """DeepRacer's name of the race type: ``time_trial``, ``object_avoidance`` or ``head_to_bot``."""
        return self.race.race_type.replace("-", "_")

    def to_dict(self) -> dict[str, Any]:
        """The rules as stored with an evaluation (``race_type`` and the ``race``'s settings included)."""
        d = asdict(self)
        d["race"] = self.race.to_dict()
        return {"race_type": self.race_type, **d}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> RaceRules:
        """Inverse of :meth:`to_dict` (unknown keys ignored; no ``race``: a time trial)."""
        keys = {"laps", "off_track_penalty", "max_resets", "time_cap_minutes", "direction"}
        keys.update(("collision_penalty", "min_laps"))
        out: dict[str, Any] = {k: v for k, v in d.items() if k in keys}
        out["race"] = RaceConfig.from_dict(d.get("race"))
        return cls(**out)


@dataclass
class LapResult:
    """One lap of a trial.

    :param lap: 1-based lap number.
    :param time: [s] simulated time plus penalties when complete, else ``None``.
    :param sim_time: [s] simulated time spent on this lap (steps / 15).
    :param progress: [%] of the lap driven.
    :param status: ``lap_complete``, ``off_track`` (resets ran out) or ``time_up``.
    :param off_track_count: times the car left the road in this lap.
    :param penalty_seconds: [s] penalties added to this lap.
    :param resets: times the car was put back on the track in this lap.
    :param crashes: collisions with boxes or bots (always 0 in a time trial).
    :param steps: steps driven in this lap.
    """

    lap: int
    time: float | None = None
    sim_time: float = 0.0
    progress: float = 0.0
    status: str = EpisodeStatus.IN_PROGRESS
    off_track_count: int = 0
    penalty_seconds: float = 0.0
    resets: int = 0
    crashes: int = 0
    steps: int = 0

    @property
    def complete(self) -> bool:
        """Whether the lap was completed."""
        return self.status == EpisodeStatus.LAP_COMPLETE

    def to_dict(self) -> dict[str, Any]:
        """A JSON-friendly dict."""
        d = asdict(self)
        d["time"] = None if self.time is None else round(self.time, 4)
        d["sim_time"] = round(self.sim_time, 4)
        d["progress"] = round(self.progress, 3)
        return d


@dataclass
class TrialResult:
    """The outcome of a time trial.

    :param rules: the rules it ran under.
    :param laps: every lap started, in order.
    :param ended: why it ended: ``laps_done``, ``time_cap`` or ``max_resets``.
    :param steps: steps driven in all.
    """

    rules: RaceRules
    laps: list[LapResult] = field(default_factory=list)
    ended: str = "running"
    steps: int = 0

    @property
    def complete_laps(self) -> list[LapResult]:
        """The laps that were completed."""
        return [lap for lap in self.laps if lap.complete]

    @property
    def laps_completed(self) -> int:
        """How many laps were completed."""
        return len(self.complete_laps)

    @property
    def fastest_lap(self) -> float | None:
        """[s] the best complete lap, penalties included."""
        times = [lap.time for lap in self.complete_laps if lap.time is not None]
        return min(times) if times else None

    @property
    def average_lap(self) -> float | None:
        """[s] the mean of the complete laps."""
        times = [lap.time for lap in self.complete_laps if lap.time is not None]
        return sum(times) / len(times) if times else None

    @property
    def total_time(self) -> float:
        """[s] the time of every lap driven, penalties included (complete or not)."""
        return sum(lap.sim_time + lap.penalty_seconds for lap in self.laps)

    @property
    def off_track_count(self) -> int:
        """Off-tracks over all laps."""
        return sum(lap.off_track_count for lap in self.laps)

    @property
    def resets(self) -> int:
        """Resets over all laps."""
        return sum(lap.resets for lap in self.laps)

    @property
    def crashes(self) -> int:
        """Crashes over all laps."""
        return sum(lap.crashes for lap in self.laps)

    @property
    def penalty_seconds(self) -> float:
        """[s] penalties over all laps."""
        return sum(lap.penalty_seconds for lap in self.laps)

    def to_dict(self) -> dict[str, Any]:
        """A JSON-friendly summary with every lap."""

        def r(v: float | None) -> float | None:
            return None if v is None else round(v, 4)

        return {
            "rules": self.rules.to_dict(),
            "ended": self.ended,
            "laps_completed": self.laps_completed,
            "fastest_lap": r(self.fastest_lap),
            "average_lap": r(self.average_lap),
            "total_time": r(self.total_time),
            "off_track_count": self.off_track_count,
            "resets": self.resets,
            "crashes": self.crashes,
            "penalty_seconds": r(self.penalty_seconds),
            "steps": self.steps,
            "laps": [lap.to_dict() for lap in self.laps],
        }


@dataclass(frozen=True)
class StepView:
    """What an observer sees after each step (for videos and progress displays).

    :param lap: the lap being driven (1-based).
    :param lap_time: [s] the lap's time so far, penalties included.
    :param total_time: [s] the trial's time so far, penalties included.
    :param progress: [%] of the current lap.
    :param status: the env's episode status of this step.
    :param event: ``""``, or what happened: ``off_track``, ``crashed``, ``immobilized``, ``reversed``,
        ``reset``, ``lap_complete``, ``time_up``, ``end``.
    :param x: rear-axle x [m].
    :param y: rear-axle y [m].
    :param yaw: [rad].
    :param speed: measured speed [m/s].
    :param steering: commanded steering [deg], + = left.
    :param observation: the camera observation of this step.
    :param laps: the laps so far (the current one last).
    :param objects: the race's boxes or bots as rows ``(x, y, yaw, length, width, height)``
        (empty in a time trial).
    :param bots: whether ``objects`` are bot cars (head-to-bot) rather than boxes.
    """

    lap: int
    lap_time: float
    total_time: float
    progress: float
    status: str
    event: str
    x: float
    y: float
    yaw: float
    speed: float
    steering: float
    observation: Any
    laps: tuple[LapResult, ...]
    objects: tuple[tuple[float, ...], ...] = ()
    bots: bool = False


Observer = Callable[[StepView], None]


def run_time_trial(
    env: Any, policy: Policy, rules: RaceRules, observer: Observer | None = None, seed: int | None = None
) -> TrialResult:
    """Drive an evaluation race (a time trial, or a race with boxes or bots).

    :param env: a ``drx/DeepRacer-v0`` env (or a wrapper of one) made with ``mode="evaluation"``
        and the race of ``rules.race``; its ``max_steps`` should exceed the time cap
        (:func:`max_steps_for`).
    :param policy: ``observation -> action``.
    :param rules: the race rules.
    :param observer: called after every step and every reset with a :class:`StepView`.
    :param seed: seeds the env's noise (its varying step lengths) for a repeatable trial; ``None``
        leaves the env's generator as it is.
    :return: the result; nothing is stored.
    """
    base = getattr(env, "unwrapped", env)
    rate = float(getattr(getattr(base, "car", None), "rate_hz", STEP_RATE))
    dt = 1.0 / rate
    cap = rules.time_cap_minutes * 60.0
    result = TrialResult(rules=rules)
    obs, info = env.reset(seed=seed, options={"start": 0.0})
    lap = LapResult(lap=1)
    result.laps.append(lap)
    elapsed = 0.0  # [s] simulated time plus penalties, all laps
    _notify(observer, base, result, lap, info, obs, elapsed, "", 0.0)
    while True:
        action = policy(obs)
        obs, _reward, terminated, truncated, info = env.step(action)
        step_time = float(info.get("step_time", dt))
        result.steps += 1
        lap.steps += 1
        lap.sim_time += step_time
        elapsed += step_time
        status = EpisodeStatus(info.get("episode_status", EpisodeStatus.IN_PROGRESS))  # the env decided it
        lap.progress = max(lap.progress, float(info.get("progress", 0.0)))
        steering = float(info.get("params", {}).get("steering_angle", 0.0))
        event = ""
        if status == EpisodeStatus.LAP_COMPLETE:
            lap.status = EpisodeStatus.LAP_COMPLETE
            lap.progress = 100.0
            lap.time = lap.sim_time + lap.penalty_seconds
            event = EpisodeStatus.LAP_COMPLETE
        elif status in RESET_STATUSES:
            if status == EpisodeStatus.OFF_TRACK:
                lap.off_track_count += 1
            if status == EpisodeStatus.CRASHED:
                lap.crashes += 1
            penalty = _penalty(rules, status)
            lap.penalty_seconds += penalty
            elapsed += penalty
            event = status
        elif terminated or truncated:  # time_up from the env's own step limit
            event = EpisodeStatus.TIME_UP
        _notify(observer, base, result, lap, info, obs, elapsed, event, steering)

        if lap.status == EpisodeStatus.LAP_COMPLETE:
            if len(result.laps) >= rules.laps:
                result.ended = "laps_done"
                break
            if elapsed >= cap:
                result.ended = "time_cap"
                break
            obs, info = env.reset(options={"start": 0.0})
            lap = LapResult(lap=lap.lap + 1)
            result.laps.append(lap)
            continue
        if elapsed >= cap or event == EpisodeStatus.TIME_UP:
            lap.status = EpisodeStatus.TIME_UP
            result.ended = "time_cap"
            break
        if event in RESET_STATUSES:
            if rules.max_resets is not None and result.resets >= rules.max_resets:
                lap.status = status  # the ending the car could not be put back from
                result.ended = "max_resets"
                break
            lap.resets += 1
            obs, info = env.reset(options={"resume": True, "pause": _penalty(rules, status)})
            _notify(observer, base, result, lap, info, obs, elapsed, "reset", 0.0)
    _notify(observer, base, result, lap, info, obs, elapsed, "end", 0.0)
    return result


def _penalty(rules: RaceRules, status: EpisodeStatus) -> float:
    """[s] the penalty an ending charges: the off-track penalty for ``off_track`` and ``reversed``, the
    collision penalty for ``crashed``, none for ``immobilized`` (deepracer-simapp
    ``bundle/markov/agent_ctrl/rollout_agent_ctrl.py``: ``REVERSE_PENALTY`` and ``IMMOBILIZED_PENALTY``
    default to the off-track penalty and 0)."""
    if status in PENALISED_RESETS:
        return rules.off_track_penalty
    if status == EpisodeStatus.CRASHED:
        return rules.collision_penalty
    return 0.0


def max_steps_for(rules: RaceRules, rate_hz: float = STEP_RATE) -> int:
    """An env ``max_steps`` that never cuts a trial under ``rules`` short."""
    return int(math.ceil(rules.time_cap_minutes * 60.0 * rate_hz)) + 10


def _notify(
    observer: Observer | None,
    base: Any,
    result: TrialResult,
    lap: LapResult,
    info: dict,
    obs: Any,
    elapsed: float,
    event: str,
    steering: float,
) -> None:
    if observer is None:
        return
    state = base.car_state
    scene = getattr(base, "scene", None)
    observer(
        StepView(
            lap=lap.lap,
            lap_time=lap.sim_time + lap.penalty_seconds,
            total_time=elapsed,
            progress=100.0 if lap.complete else float(info.get("progress", lap.progress)),
            status=str(info.get("episode_status", "")),
            event=event,
            x=float(state.x),
            y=float(state.y),
            yaw=float(state.yaw),
            speed=float(state.speed),
            steering=steering,
            observation=obs,
            laps=tuple(result.laps),
            objects=tuple(scene.rows()) if scene is not None else (),
            bots=bool(scene is not None and scene.moving),
        )
    )
