"""Evaluations: check the request, run the race, store the result, read results back.

The flow of ``drx evaluate`` (and of an ``evaluate`` job):

1. :func:`prepare` checks everything before the car moves: the model, its
   checkpoint, the track, the race (the model's race type with its boxes or
   bots, or the request's) and the rules. Every problem is a :class:`DrxError`
   sentence, and nothing has been stored. It also computes the theoretical best
   lap, the reference each lap is compared with; where there is none (a car
   whose steering cannot bend round the track's tightest bend on any line the
   solver finds) the race is still run, as DeepRacer runs it, and the result
   says "no best lap" and why (:attr:`Prepared.best_missing`).
2. :func:`run` drives the trial (:func:`drx.evaluate.time_trial.run_time_trial`).
3. :func:`store` writes the evaluation and its laps in one transaction, only
   once the trial has ended, so an interrupted evaluation (Ctrl-C) leaves no
   row behind.
"""

from __future__ import annotations

import contextlib
import os
import secrets
import shutil
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from sqlalchemy import select

from drx.errors import DrxError, NotFoundError, SettingError
from drx.evaluate.policy import ModelPolicy
from drx.evaluate.ranking import longest_run
from drx.evaluate.theoretical_lap import BestLap, best_lap
from drx.evaluate.time_trial import Observer, Policy, RaceRules, TrialResult, max_steps_for, run_time_trial
from drx.registry import Evaluation, EvaluationLap, Model, session_scope, utcnow
from drx.services.checkpoints import ChosenCheckpoint, choose_checkpoint
from drx.services.models import get_model, model_artifacts_dir
from drx.services.tracks import find_track, load_entry
from drx.settings.car import DEFAULT_SIMULATOR, check_simulator
from drx.settings.race import RaceConfig, normalise_race_type
from drx.settings.seed import check_seed
from drx.sim.dynamics import CarParams
from drx.sim.track import Track
from drx.storage import get_store
from drx.vehicle import Vehicle

DIRECTIONS = ("cw", "ccw")
RULE_KEYS = (
    "race_type",
    "laps",
    "off_track_penalty",
    "collision_penalty",
    "max_resets",
    "time_cap_minutes",
    "min_laps",
)


@dataclass(frozen=True)
class EvaluationRequest:
    """What ``drx evaluate`` was asked to do.

    :param model: the model's name.
    :param track: the track's name (default: the model's training track).
    :param checkpoint: ``best``, ``last`` or an iteration number.
    :param laps: laps to drive, 1-100.
    :param off_track_penalty: [s] per off-track, >= 0.
    :param max_resets: resets allowed (``None``: no limit).
    :param time_cap_minutes: the trial's time cap.
    :param direction: ``cw`` or ``ccw`` to drive the loop that way; ``None`` for the track's own.
    :param race: race settings that replace the model's (:func:`race_for`); ``None``: the model's race.
    :param collision_penalty: [s] per crash into a box or bot, >= 0.
    :param seed: seeds the simulator's noise (DeepRacer's varying step lengths), so a trial can be
        repeated exactly; ``None``: a fresh seed, stored with the evaluation.
    :param min_laps: complete laps in a row the result needs to qualify for the leaderboard, 1 to
        ``laps``; ``None``: no minimum.
    :param simulator: race on this DeepRacer simulator's car (``"5"`` or ``"6"``); ``None``: the one
        the model trains on (:mod:`drx.settings.car`).
    """

    model: str
    track: str | None = None
    checkpoint: str = "best"
    laps: int = 3
    off_track_penalty: float = 2.0
    max_resets: int | None = None
    time_cap_minutes: float = 20.0
    direction: str | None = None
    race: dict[str, Any] | None = None
    collision_penalty: float = 5.0
    seed: int | None = None
    min_laps: int | None = None
    simulator: str | None = None

    def to_options(self) -> dict[str, Any]:
        """The request as a job's options (JSON)."""
        return {k: getattr(self, k) for k in self.__dataclass_fields__}

    @classmethod
    def from_options(cls, options: dict[str, Any]) -> EvaluationRequest:
        """Inverse of :meth:`to_options`."""
        return cls(**{k: v for k, v in options.items() if k in cls.__dataclass_fields__})


@dataclass
class Prepared:
    """A checked request, ready to race.

    :param model_id: the model's id.
    :param model_name: its name.
    :param vehicle: its car.
    :param track: the track, in the driving direction of the race.
    :param track_name: the track's name.
    :param rules: the race rules.
    :param checkpoint: the checkpoint to drive.
    :param best: the theoretical best lap of this car on this track; ``None`` when there is none.
    :param seed: the seed of the simulator's noise for this trial.
    :param best_missing: why there is no best lap (a sentence), or ``""``.
    :param simulator: the DeepRacer simulator whose car races (``"5"`` or ``"6"``).
    """

    model_id: int
    model_name: str
    vehicle: Vehicle
    track: Track
    track_name: str
    rules: RaceRules
    checkpoint: ChosenCheckpoint
    best: BestLap | None
    extra: dict[str, Any] = field(default_factory=dict)
    seed: int = 0
    best_missing: str = ""
    simulator: str = DEFAULT_SIMULATOR

    @property
    def car(self) -> CarParams:
        """The simulator's car that races."""
        return CarParams.for_simulator(self.simulator)

    @property
    def best_lap_time(self) -> float | None:
        """[s] The theoretical best lap, or ``None`` when there is none."""
        return None if self.best is None else self.best.lap_time

    @property
    def best_lap_text(self) -> str:
        """The best lap for people: ``theoretical best lap 7.130 s`` or ``no best lap: <reason>``."""
        if self.best is None:
            return f"no best lap: {self.best_missing}"
        return f"theoretical best lap {self.best.lap_time:.3f} s"


def prepare(request: EvaluationRequest) -> Prepared:
    """Check a request (see the module docstring); nothing is stored.

    :raises DrxError: unknown model, no checkpoint, unknown track, bad rules.
    """
    model: Model = get_model(request.model)
    checked = RaceRules(  # the rules' own checks first: they need no file
        laps=request.laps,
        off_track_penalty=request.off_track_penalty,
        max_resets=request.max_resets,
        time_cap_minutes=request.time_cap_minutes,
        collision_penalty=request.collision_penalty,
        min_laps=request.min_laps,
    )
    check_seed(request.seed)
    simulator = check_simulator(request.simulator) if request.simulator is not None else None
    race = race_for(model.race_config(), request.race)
    checkpoint = choose_checkpoint(model, request.checkpoint)
    entry = find_track(request.track or model.track_name)  # resolved once: a route id or display name
    track_name = entry.name
    base = load_entry(entry)
    reverse = _reverse(base, request.direction or _trained_direction(model, track_name), track_name)
    rules = replace(checked, race=race, direction="reverse" if reverse else "default")
    track = base.reversed() if reverse else base
    vehicle = model.vehicle()
    simulator = simulator or model.car_settings().simulator
    car = CarParams.for_simulator(simulator)
    best, best_missing = _best_lap(track, vehicle, track_name, model.vehicle_name, car)
    return Prepared(
        model_id=model.id,
        model_name=model.name,
        vehicle=vehicle,
        track=track,
        track_name=track_name,
        rules=rules,
        checkpoint=checkpoint,
        best=best,
        extra={"car": model.vehicle_name, "simulator": simulator},
        seed=request.seed if request.seed is not None else default_seed(),
        best_missing=best_missing,
        simulator=simulator,
    )


def default_seed() -> int:
    """The seed of an evaluation given none: ``DRX_EVALUATION_SEED`` when set (scripts and tests that
    want repeatable trials), else a fresh one (stored with the evaluation, so it can be repeated).

    :raises DrxError: when ``DRX_EVALUATION_SEED`` is not a whole number.
    """
    text = os.environ.get("DRX_EVALUATION_SEED", "").strip()
    if not text:
        return secrets.randbelow(2**31)
    try:
        return int(text) % 2**32
    except ValueError:
        raise DrxError(
            f"DRX_EVALUATION_SEED={text!r} is not a whole number; set a number or unset it."
        ) from None


def race_for(model_race: RaceConfig, changes: dict[str, Any] | None) -> RaceConfig:
    """The race of an evaluation: the model's, with the request's settings.

    A different ``race_type`` starts from that race type's defaults; otherwise the given
    settings replace the model's one by one (``objects`` without ``object_positions`` drops
    the model's own box places; ``object_positions`` alone sets the box count). An evaluation
    always keeps its boxes and bots where they start (the env's evaluation mode), so the
    race is stored without randomisation.

    :raises DrxError: settings out of DeepRacer's ranges (one sentence).
    """
    changes = {k: v for k, v in (changes or {}).items() if v is not None}
    kind = changes.pop("race_type", None)
    # a head-to-model model's opponents drive its training; its evaluation is a time trial (drx race
    # is where it meets them)
    base = model_race if model_race.race_type != "head-to-model" else RaceConfig()
    if kind is not None and normalise_race_type(kind) == "head-to-model":
        raise DrxError("An evaluation races one car; race models against each other with drx race.")
    if kind is not None and RaceConfig(kind).race_type != model_race.race_type:
        base = RaceConfig(kind)
    current = base.to_dict()
    if "object_positions" in changes:
        changes["object_positions"] = tuple(tuple(p) for p in changes["object_positions"])
        if "objects" not in changes:
            changes["objects"] = None
    elif "objects" in changes:
        changes["object_positions"] = ()
    current.update(changes, randomize_objects=False, randomize_bots=False)
    if not current["object_positions"]:
        current["object_positions"] = ()
    current["object_positions"] = tuple(tuple(p) for p in current["object_positions"])
    return RaceConfig(**current)


def _trained_direction(model: Model, track_name: str) -> str | None:
    """The direction the model trains its own track in, when it drives that route reversed (a
    direction with no ``_cw``/``_ccw`` route, ``drx model create --direction``): its default
    evaluation goes that way too. ``None`` otherwise (the route's own way)."""
    first = model.episode_settings().first
    if first is None or first.name != track_name or not first.reverse:
        return None
    return first.direction


def _reverse(track: Track, direction: str | None, name: str) -> bool:
    """Whether the race drives ``track`` backwards to go ``direction``."""
    if direction is None:
        return False
    if direction not in DIRECTIONS:
        raise SettingError("{field} {value!r} is unknown; use cw or ccw.", "direction", value=direction)
    if not track.closed:
        raise SettingError(
            "Track {track!r} is not a loop; {field} applies to loops only.", "direction", track=name
        )
    return direction != track.direction


def _best_lap(
    track: Track, vehicle: Vehicle, track_name: str, car_name: str, car: CarParams | None = None
) -> tuple[BestLap | None, str]:
    """The theoretical best lap of the race, or ``None`` and why there is none.

    The best lap is a reference shown beside the result (each lap's ratio to it), not a condition of
    the race: DeepRacer races any car on any of its tracks, and a car whose steering cannot bend round
    a bend leaves the road there, off-track penalties and all. So a best lap that cannot be computed
    does not stop the evaluation.
    """
    try:
        return best_lap(track, vehicle, car), ""
    except DrxError as exc:  # the car's steering lock is too small for the tightest bend of every line
        return None, str(exc)
    except ValueError as exc:  # racing_line's corridor: the road is narrower than the line's clearance
        return None, f"Car {car_name!r} on track {track_name!r}: {exc}"


def make_env(prepared: Prepared, render: bool = False) -> Any:
    """The evaluation env for a prepared race (``params["racing_line"]`` included, as in training)."""
    from drx.evaluate.theoretical_lap import PARAMS_KEY, racing_line_waypoints
    from drx.sim.env import DeepRacerEnv

    return DeepRacerEnv(
        track=prepared.track,
        vehicle=prepared.vehicle,
        mode="evaluation",
        car=prepared.car,
        race=prepared.rules.race,
        max_steps=max_steps_for(prepared.rules),
        render_mode="rgb_array" if render else None,
        extra_params={PARAMS_KEY: racing_line_waypoints(prepared.track)},
    )


def run(
    prepared: Prepared,
    policy: Policy | None = None,
    observer: Observer | None = None,
    video: Path | None = None,
    env: Any | None = None,
) -> TrialResult:
    """Drive the trial with the checkpoint's policy (or ``policy``); stores nothing.

    :param video: also record the trial to this ``.mp4`` / ``.gif`` file (removed again when the
        trial is interrupted).
    :param env: the env to drive, made by :func:`make_env` (a scripted ``policy`` reads its car);
        default a new one.
    """
    from drx.analysis.eval_trace import EvaluationTraceWriter
    from drx.watch.live import LivePoseWriter

    # Every trial leaves a deepracer-for-cloud evaluation trace in the model's folder
    # (read by deepracer-utils and `drx analyze`); an interrupted trial removes it again.
    # The policy loads (seconds) before the trace folder exists: an interruption meanwhile leaves nothing.
    driver = policy or ModelPolicy(prepared.checkpoint.path, prepared.vehicle)
    base_env = env if env is not None else make_env(prepared)
    folder = model_artifacts_dir(prepared.model_name)
    env = EvaluationTraceWriter(
        LivePoseWriter(base_env, folder, "evaluation"), folder, prepared.vehicle.continuous
    )  # the pose file lets `drx watch` show the race
    completed = False
    try:
        if video is None:
            result = run_time_trial(env, driver, prepared.rules, observer, seed=prepared.seed)
            completed = True
            return result
        from drx.evaluate.video import TrialVideo

        writer = TrialVideo(
            video,
            prepared.track,
            title=f"{prepared.model_name} on {prepared.track_name}",
            racing_line=None if prepared.best is None else prepared.best.line.points,
            best_lap=prepared.best_lap_time,
            laps=prepared.rules.laps,
            top_speed=prepared.vehicle.max_speed,
            max_steering=prepared.vehicle.max_steering,
        )
        writer.open()
        try:
            result = run_time_trial(env, driver, prepared.rules, _both(writer, observer), seed=prepared.seed)
        except BaseException:
            writer.close(hold=False)
            Path(video).unlink(missing_ok=True)
            raise
        writer.close()
        completed = True
        get_store().put(prepared.model_name, f"videos/{env.folder.name}{Path(video).suffix}", Path(video))
        return result
    finally:
        env.close()
        if not completed:
            shutil.rmtree(env.folder, ignore_errors=True)
        else:  # the evaluation trace, for analyses on any host
            get_store().push_tree(prepared.model_name, [env.folder.name])


def _both(first: Observer, second: Observer | None) -> Observer:
    if second is None:
        return first

    def call(view: Any) -> None:
        first(view)
        second(view)

    return call


def store(
    prepared: Prepared, result: TrialResult, job_id: int | None = None, video: Path | None = None
) -> int:
    """Write the evaluation and its laps in one transaction; returns the evaluation's id."""
    rules = prepared.rules.to_dict()
    rules.update(
        checkpoint=prepared.checkpoint.which,
        checkpoint_iteration=prepared.checkpoint.iteration,
        best_lap=None if prepared.best is None else round(prepared.best.lap_time, 4),
        best_lap_missing=prepared.best_missing or None,
        ended=result.ended,
        steps=result.steps,
        resets=result.resets,
        car=prepared.extra.get("car"),
        simulator=prepared.simulator,
        action_space=prepared.vehicle.summary(),
        video=str(video) if video else None,
        seed=prepared.seed,
    )
    with session_scope() as session:
        row = Evaluation(
            model_id=prepared.model_id,
            checkpoint_id=prepared.checkpoint.row_id,
            job_id=job_id,
            track_name=prepared.track_name,
            rules=rules,
            status="complete",
            laps_completed=result.laps_completed,
            fastest_lap=result.fastest_lap,
            average_lap=result.average_lap,
            total_time=result.total_time,
            off_track_count=result.off_track_count,
            crash_count=result.crashes,
            finished_at=utcnow(),
        )
        row.laps = [
            EvaluationLap(
                lap=lap.lap,
                time=lap.time,
                progress=lap.progress,
                status=lap.status,
                off_track_count=lap.off_track_count,
                penalty_seconds=lap.penalty_seconds,
                resets=lap.resets,
                crashes=lap.crashes,
            )
            for lap in result.laps
        ]
        session.add(row)
        session.flush()
        return int(row.id)


# ----- reading results back ----------------------------------------------------------------------


def evaluation_dict(row: Evaluation, model_name: str) -> dict[str, Any]:
    """An evaluation as the console's summary: totals, rules and every lap with its ratio to the best lap."""
    rules = dict(row.rules or {})
    best = rules.get("best_lap")
    race = RaceConfig.from_dict(rules.get("race"))

    def ratio(t: float | None) -> float | None:
        return round(t / best, 3) if t is not None and best else None

    return {
        "id": row.id,
        "model": model_name,
        "car": rules.get("car"),
        "simulator": rules.get("simulator"),  # whose car raced; None: before simulator 6 (version 5's)
        "action_space": rules.get("action_space"),
        "track": row.track_name,
        "direction": rules.get("direction", "default"),
        "race": race.summary(),
        "race_settings": race.to_dict(),
        "checkpoint": rules.get("checkpoint"),
        "checkpoint_iteration": rules.get("checkpoint_iteration"),
        "status": row.status,
        "ended": rules.get("ended"),
        "rules": {k: rules.get(k) for k in RULE_KEYS},  # a key older rows lack reads None (min_laps: none)
        "qualified": _qualified(rules.get("min_laps"), row.laps),
        "laps_completed": row.laps_completed,
        "fastest_lap": row.fastest_lap,
        "average_lap": row.average_lap,
        "total_time": row.total_time,
        "off_track_count": row.off_track_count,
        "crash_count": row.crash_count,
        "resets": rules.get("resets"),
        "best_lap": best,
        "best_lap_missing": rules.get("best_lap_missing"),  # why best_lap is None, when it is
        "fastest_lap_ratio": ratio(row.fastest_lap),
        "video": rules.get("video"),
        "seed": rules.get("seed"),  # of the simulator's noise: `drx evaluate --seed` repeats the trial
        "created_at": row.created_at,
        "laps": [
            {
                "lap": lap.lap,
                "time": lap.time,
                "ratio": ratio(lap.time),
                "progress": round(lap.progress, 2),
                "status": lap.status,
                "off_track_count": lap.off_track_count,
                "penalty_seconds": lap.penalty_seconds,
                "resets": lap.resets,
                "crashes": lap.crashes,
            }
            for lap in row.laps
        ],
    }


def _qualified(min_laps: int | None, laps: list[EvaluationLap]) -> bool:
    """Whether a result meets its rules' minimum lap count (complete laps in a row; none: always)."""
    return not min_laps or longest_run(lap.time is not None for lap in laps) >= min_laps


def get_evaluation(evaluation_id: int) -> dict[str, Any]:
    """One evaluation as :func:`evaluation_dict`.

    :raises NotFoundError: no such evaluation.
    """
    with session_scope() as session:
        row = session.get(Evaluation, evaluation_id)
        if row is None:
            raise NotFoundError(f"No evaluation {evaluation_id}; see `drx eval list`.")
        name = session.scalar(select(Model.name).where(Model.id == row.model_id)) or "?"
        return evaluation_dict(row, name)


def list_evaluations(
    model: str | None = None, track: str | None = None, limit: int = 50
) -> list[dict[str, Any]]:
    """Recent evaluations, newest first, as :func:`evaluation_dict` (laps included); ``track`` may be
    a display name (a removed imported track's name still filters)."""
    if track is not None:
        with contextlib.suppress(NotFoundError):
            track = find_track(track).name
    with session_scope() as session:
        query = select(Evaluation, Model.name).join(Model, Model.id == Evaluation.model_id)
        if model is not None:
            get_model(model)  # a clear error for an unknown name
            query = query.where(Model.name == model)
        if track is not None:
            query = query.where(Evaluation.track_name == track)
        rows = session.execute(query.order_by(Evaluation.id.desc()).limit(limit)).all()
        return [evaluation_dict(row, name) for row, name in rows]
