"""``drx race``: check the models, race them head-to-head, keep each car's trace, store the race.

The flow, as :mod:`drx.evaluate.service`'s for one car:

1. :func:`prepare` checks everything before a car moves: two to four models, none twice, each
   trained (a checkpoint) and trained on the race's track in the race's direction. Every
   problem is one sentence (:class:`~drx.errors.DrxError`, exit 2) and nothing is stored.
2. :func:`run` makes one env per car (its own car, sensors and constants, the other cars in its
   scene), wraps each in the evaluation trace writer (``drx analyze`` reads it) and the live pose
   writer (``drx watch`` shows it), and drives :func:`drx.evaluate.head_to_head.run_head_to_head`.
3. :func:`drx.evaluate.race_store.store_race` writes the race and its cars in one transaction.
"""

from __future__ import annotations

import math
import shutil
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from drx.errors import DrxError, SettingError
from drx.evaluate.head_to_head import (
    CARS_RANGE,
    HeadToHeadRules,
    RaceObserver,
    RaceResult,
    SharedClock,
    run_head_to_head,
)
from drx.evaluate.policy import ModelPolicy
from drx.evaluate.time_trial import Policy
from drx.services.checkpoints import ChosenCheckpoint, choose_checkpoint
from drx.services.models import get_model, model_artifacts_dir
from drx.services.tracks import find_track, load_entry
from drx.settings.seed import check_seed
from drx.sim.dynamics import CarParams
from drx.sim.track import Track
from drx.vehicle import Vehicle


@dataclass(frozen=True)
class Racer:
    """One checked model of a race.

    :param model_id: its id.
    :param name: its name.
    :param vehicle: its car (action space, sensors, network).
    :param car: its physical constants (``CarParams``, as its time trials get them).
    :param checkpoint: the checkpoint that drives.
    """

    model_id: int
    name: str
    vehicle: Vehicle
    car: CarParams
    checkpoint: ChosenCheckpoint


@dataclass
class PreparedRace:
    """A checked race, ready to run.

    :param racers: the cars in start order (``racecar_0`` first).
    :param track: the track in the race's direction.
    :param track_name: its name.
    :param direction: ``cw`` / ``ccw`` (``-`` for an open track).
    :param rules: the race's rules.
    :param seed: the seed of the race's noise.
    :param traces: each car's evaluation trace folder, once :func:`run` has run.
    """

    racers: list[Racer]
    track: Track
    track_name: str
    direction: str
    rules: HeadToHeadRules
    seed: int
    traces: dict[str, Path] = field(default_factory=dict)


def car_params_for(model: Any) -> CarParams:
    """The physical constants a model's car races with: its simulator's car, as its time trials
    (``drx.settings.car``: 6 for new models, 5 for those from before)."""
    return CarParams.for_simulator(model.car_settings().simulator)


def prepare(
    models: list[str], track: str, rules: HeadToHeadRules, seed: int | None = None, checkpoint: str = "best"
) -> PreparedRace:
    """Check a race (see the module docstring); nothing is stored.

    :raises DrxError: fewer than two or more than four models, a model twice, an unknown or
        untrained model, a model trained on another track or in another direction.
    """
    from drx.evaluate.service import default_seed

    lo, hi = CARS_RANGE
    if not lo <= len(models) <= hi:
        raise SettingError(
            "A race takes {lo} to {hi} models, not {n}; name {lo} to {hi} of them.", "models",
            lo=lo, hi=hi, n=len(models),
        )  # fmt: skip
    check_seed(seed)
    entry, base, racers, direction = check_models(models, track, checkpoint)
    reverse = base.closed and direction != base.direction
    rules = replace(rules, direction="reverse" if reverse else "default")
    return PreparedRace(
        racers=racers,
        track=base.reversed() if reverse else base,
        track_name=entry.name,
        direction=direction,
        rules=rules,
        seed=seed if seed is not None else default_seed(),
    )


def check_models(
    models: list[str], track: str, checkpoint: str = "best"
) -> tuple[Any, Track, list[Racer], str]:
    """Check models for one race or a bracket: none twice, each trained, each on ``track`` in one
    direction; returns the track's catalogue entry, its route, the racers and the direction.

    :raises DrxError: one sentence naming the model and the fix.
    """
    twice = sorted({m for m in models if models.count(m) > 1})
    if twice:
        raise DrxError(f"Model {twice[0]!r} is named twice; each model drives one car, so name it once.")
    entry = find_track(track)
    base = load_entry(entry)
    if not base.closed:  # the grid staggers cars behind the line: DeepRacer races several cars on loops
        raise DrxError(f"Track {entry.name!r} is not a loop; race models against each other on a loop.")
    racers, directions = [], {}
    for name in models:
        model = get_model(name)
        if model.track_name != entry.name:
            raise DrxError(
                f"Model {name!r} was trained on {model.track_name!r}, not {entry.name!r}; race models "
                f"on the track they trained on (--track {model.track_name}) or leave {name!r} out."
            )
        chosen = choose_checkpoint(model, checkpoint)
        directions[name] = _direction(model, base)
        racers.append(Racer(model.id, model.name, model.vehicle(), car_params_for(model), chosen))
    if len(set(directions.values())) > 1:
        ways = ", ".join(f"{m} {d}" for m, d in directions.items())
        raise DrxError(
            f"The models drive {entry.name!r} in different directions ({ways}); race models trained "
            "in the same direction."
        )
    return entry, base, racers, next(iter(directions.values()))


def _direction(model: Any, track: Track) -> str:
    """The way a model drives its training track: its recorded direction, else the route's own."""
    first = model.episode_settings().first
    if first is not None and first.name == model.track_name and first.direction:
        return str(first.direction)
    return track.direction


def make_envs(prepared: PreparedRace, clock: SharedClock) -> list[Any]:
    """One evaluation env per car: its car and sensors, the shared clock, the other cars as its scene."""
    from drx.evaluate.theoretical_lap import PARAMS_KEY, racing_line_waypoints
    from drx.sim.env import DeepRacerEnv
    from drx.sim.race_cars import OtherCars

    line = {PARAMS_KEY: racing_line_waypoints(prepared.track)}
    # never the env's step limit first: a noisy step lasts at least half the mean (drx.sim.noise)
    rate = max(r.car.rate_hz for r in prepared.racers)
    steps = int(math.ceil(prepared.rules.time_cap_minutes * 60.0 * rate * 2.0)) + 10
    envs = []
    for i, racer in enumerate(prepared.racers):
        env = DeepRacerEnv(
            track=prepared.track, vehicle=racer.vehicle, mode="evaluation", car=racer.car,
            max_steps=steps, extra_params=line, clock=clock,
        )  # fmt: skip
        others = [r.car for j, r in enumerate(prepared.racers) if j != i]
        env.scene = OtherCars(prepared.track, racer.car, others)
        envs.append(env)
    return envs


def run(
    prepared: PreparedRace,
    policies: list[Policy] | None = None,
    observer: RaceObserver | None = None,
    video: Path | None = None,
) -> RaceResult:
    """Race the prepared cars with their checkpoints' policies (or ``policies``); stores nothing.

    Each car's steps go to an evaluation trace in its model's folder (``evaluation-<time>``, the
    format ``drx analyze`` reads; :attr:`PreparedRace.traces`), removed again when the race is
    interrupted; ``video`` records the race (:mod:`drx.evaluate.race_video`).
    """
    import numpy as np

    from drx.analysis.eval_trace import EvaluationTraceWriter
    from drx.sim.noise import StepNoise
    from drx.watch.live import LivePoseWriter

    drivers = policies or [ModelPolicy(r.checkpoint.path, r.vehicle) for r in prepared.racers]
    # one clock for the race (DeepRacer's one Gazebo world): its step lengths are racecar_0's simulator's
    clock = SharedClock(StepNoise(prepared.racers[0].car, np.random.default_rng(prepared.seed)))
    envs = []
    for racer, env in zip(prepared.racers, make_envs(prepared, clock), strict=True):
        folder = model_artifacts_dir(racer.name)
        envs.append(EvaluationTraceWriter(LivePoseWriter(env, folder, "evaluation"), folder,
                                          racer.vehicle.continuous))  # fmt: skip
    completed = False
    writer: Any = None
    try:
        if video is not None:
            from drx.evaluate.race_video import RaceVideo

            laps = prepared.rules.laps
            title = f"{prepared.track_name}, {laps} lap{'' if laps == 1 else 's'}"
            writer = RaceVideo(video, prepared.track, [r.name for r in prepared.racers], title=title)
            writer.open()
        watch = _both(writer, observer)
        result = run_head_to_head(envs, drivers, [r.name for r in prepared.racers], prepared.rules, clock,
                                  seed=prepared.seed, observer=watch)  # fmt: skip
        if writer is not None:
            writer.close()
        completed = True
        prepared.traces = {r.name: env.folder for r, env in zip(prepared.racers, envs, strict=True)}
        return result
    finally:
        for env in envs:
            env.close()
        if not completed:
            if writer is not None:
                writer.close(hold=False)
                Path(str(video)).unlink(missing_ok=True)
            for env in envs:
                shutil.rmtree(env.folder, ignore_errors=True)


def _both(first: RaceObserver | None, second: RaceObserver | None) -> RaceObserver | None:
    if first is None or second is None:
        return first or second

    def call(view: Any) -> None:
        first(view)
        second(view)

    return call
