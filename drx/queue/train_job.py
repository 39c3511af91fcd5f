"""The ``train`` job's runner (:data:`drx.queue.kinds.KINDS`), called by :func:`drx.queue.dispatch.run_job`.

It builds the trainer from the model's registry row, resumes from the model's
last checkpoint when one exists (a clone starts from its parent's best), writes
its records to the registry, and says how the training ended; the dispatcher
claims the job, beats its heart and records that ending.
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path
from typing import Any

import gymnasium as gym
from sqlalchemy import select

from drx.errors import DrxError, SettingError, not_a_file
from drx.evaluate.head_to_model import load_opponents, with_opponents
from drx.queue import lifecycle
from drx.queue.dispatch import JobOutcome, JobRun
from drx.queue.registry_sink import RegistrySink, truncate_after
from drx.registry import Checkpoint, Job, Model, RewardSource, session_scope
from drx.services.models import model_artifacts_dir
from drx.services.rewards import check_trusted
from drx.services.tracks import find_track
from drx.settings.device import job_device
from drx.settings.stop import StopConditions
from drx.sim import reward_guard
from drx.sim.dynamics import CarParams
from drx.sim.schedule import ScheduledEnv
from drx.storage import get_store
from drx.storage.base import MODEL_FILES
from drx.train.checkpoint import checkpoint_path, read_meta
from drx.train.device import describe_device, device_label, resolve_device
from drx.train.records import MultiSink, TrainingSink
from drx.train.rollout import default_rollout_workers
from drx.train.stop import REQUESTED
from drx.train.storing_sink import StoringSink
from drx.train.trainer import Trainer, TrainingSpec


def torch_threads() -> int:
    """Threads torch may use here: ``$DRX_TORCH_THREADS``, else every core this process may run on."""
    env = os.environ.get("DRX_TORCH_THREADS")
    if env:
        return max(1, int(env))
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


def _reward_file(folder: Path, model: Model) -> Path:
    """The model's reward code, written beside its checkpoints (errors then name this file)."""
    path = folder / "reward_function.py"
    with session_scope() as session:
        check_trusted(session, model.reward_sha256, model.name)
        code = session.get_one(RewardSource, model.reward_sha256).code
    if not path.is_file() or path.read_text() != code:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(".py.tmp")
        tmp.write_text(code)
        os.replace(tmp, path)
    return path


def _init_checkpoint(model: Model, options: dict[str, Any]) -> Path | None:
    """Where a model without checkpoints starts: the job's ``checkpoint`` file, else its parent's best."""
    given = options.get("checkpoint")
    if given:
        path = Path(given).expanduser()
        if not path.is_file():
            raise not_a_file(given, "Checkpoint file", "give a checkpoint .zip file")
        return path
    if model.parent_id is None:
        return None
    with session_scope() as session:
        row = None
        if model.parent_checkpoint_id is not None:
            row = session.get(Checkpoint, model.parent_checkpoint_id)
        if row is None or not _fetched(row.path).is_file():
            row = session.scalar(
                select(Checkpoint)
                .where(Checkpoint.model_id == model.parent_id)
                .order_by(Checkpoint.is_best.desc(), Checkpoint.iteration.desc())
                .limit(1)
            )
    if row is None or not _fetched(row.path).is_file():
        raise DrxError(
            f"Model {model.name!r} is a clone of {model.parent_name!r}, which has no checkpoint to start "
            "from; train the parent first or give --checkpoint."
        )
    return _fetched(row.path)


def _fetched(stored: str) -> Path:
    """The local copy of a checkpoint the registry names (from the artifact store when it is there)."""
    return get_store().local_path(stored)


def stop_conditions_for(job: Job, model: Model) -> StopConditions:
    """A job's stop conditions: the model's, overridden by the job's options."""
    return model.stop_settings((job.options or {}).get("stop"))


def build_spec(job: Job, model: Model) -> TrainingSpec:
    """The trainer's :class:`TrainingSpec` for a job of a model.

    :raises SettingError: the job's device (:func:`drx.settings.device.job_device`) is one this
        machine cannot use.
    """
    options = dict(job.options or {})
    device = resolve_device(job_device(options.get("device"), model.device))  # first: nothing to undo
    vehicle = model.vehicle()
    race = model.race_config()
    opponents = load_opponents(race)  # head-to-model: the models driving the other cars (else none)
    rollout = model.rollout_settings()
    randomize = rollout.domain_randomization
    car_settings = model.car_settings()  # the simulator whose car it trains on (drx.settings.car)
    hp = model.hyperparameter_settings()
    stop = stop_conditions_for(job, model)
    folder = model_artifacts_dir(model.name)
    get_store().pull_tree(model.name, MODEL_FILES)  # another host may have trained it last
    episodes = model.episode_settings()  # its tracks (the first is track_name), their direction, starts
    track_paths = [find_track(name).path for name in episodes.track_names]
    first_reversed = episodes.tracks[0].reverse
    reward_path = _reward_file(folder, model)
    has_own = checkpoint_path(folder, "last").is_file()
    if has_own and options.get("checkpoint"):
        raise SettingError(
            "Model {model!r} already has checkpoints, so training continues from its last one; "
            "{field} applies only to a model's first training (clone the model to start elsewhere).",
            "checkpoint",
            model=model.name,
        )
    init = None if has_own else _init_checkpoint(model, options)

    # params["racing_line"] for reward functions, per track and direction (~0.1-1 s each, computed
    # when an env of that track and direction is first built; a rollout worker gets those computed so far)
    racing_lines: dict[tuple[int, bool], Any] = {}

    def make_track_env(mode: str, index: int, reverse: bool) -> gym.Env:
        from drx.evaluate.theoretical_lap import PARAMS_KEY, racing_line_waypoints
        from drx.sim.registration import ENV_ID, register_envs
        from drx.sim.track import load_track

        register_envs()
        if (index, reverse) not in racing_lines:
            track = load_track(track_paths[index])
            racing_lines[index, reverse] = racing_line_waypoints(track.reversed() if reverse else track)
        return with_opponents(lambda clock: gym.make(
            ENV_ID,
            track=str(track_paths[index]),
            reverse=reverse,  # a direction the route has no _cw/_ccw variant for (DeepRacer's REVERSE_DIR)
            vehicle=vehicle,
            reward_function=str(reward_path),
            mode=mode,
            race=race,  # boxes or bots of an object-avoidance / head-to-bot model
            domain_randomization=randomize and mode == "training",  # evaluations see the usual look
            car=CarParams.for_simulator(car_settings.simulator),
            car_randomization=car_settings.car_randomization and mode == "training",
            extra_params={PARAMS_KEY: racing_lines[index, reverse]},
            clock=clock,
            disable_env_checker=True,
        ), opponents if mode == "training" else [])  # fmt: skip

    def make_env(mode: str) -> gym.Env:
        from drx.watch.live import LivePoseWriter

        env: gym.Env
        if mode == "training":  # each episode on its track, its way, from its start (drx.sim.schedule)
            env = ScheduledEnv(episodes, lambda index, reverse: make_track_env(mode, index, reverse))
        else:  # the trainer's evaluation drives the model's first track, the way it trains on it
            env = make_track_env(mode, 0, first_reversed)
        return LivePoseWriter(env, folder, mode)  # the car's latest pose, for `drx watch`

    return TrainingSpec(
        vehicle=vehicle,
        hyperparameters=hp,
        stop=stop,
        folder=folder,
        env_factory=make_env,
        eval_episodes=int(options.get("eval_episodes", 3)),
        seed=options.get("seed"),
        init_checkpoint=init,
        run_key=f"job-{job.id}",
        threads=int(options.get("threads") or torch_threads()),
        rollout_workers=int(
            options.get("rollout_workers")
            or rollout.rollout_workers
            or default_rollout_workers(torch_threads())
        ),
        device=device,
        simulator=car_settings.simulator,
    )


def _record_device(job_id: int, device: str) -> None:
    """Keep the device this attempt trains on with the job's other run facts (``drx jobs show``)."""
    with session_scope() as session:
        session.get_one(Job, job_id).device = device_label(device)[:128]


def _sync_rows_with_checkpoint(model_id: int, job_id: int, folder: Path) -> None:
    """Before (re)starting: drop rows past the last checkpoint, and add its row if a crash lost it."""
    last = checkpoint_path(folder, "last")
    meta = read_meta(last) if last.is_file() else {}
    iteration = int(meta.get("iteration", -1))
    truncate_after(model_id, iteration)
    if iteration < 0:
        return
    with session_scope() as session:
        exists = session.scalar(
            select(Checkpoint.id).where(Checkpoint.model_id == model_id, Checkpoint.iteration == iteration)
        )
        if exists is None:
            session.add(
                Checkpoint(
                    model_id=model_id,
                    job_id=job_id,
                    iteration=iteration,
                    path=get_store().stored_path(folder.name, last),
                    steps=int(meta.get("steps", 0)),
                    episodes=int(meta.get("episodes", 0)),
                    eval_progress=meta.get("eval_progress"),
                    eval_lap_time=meta.get("eval_lap_time"),
                    is_best=False,
                )
            )


def run_training(run: JobRun) -> JobOutcome:
    """The runner of ``train`` jobs: train the job's model until a stop condition, a stop request or Ctrl-C.

    :param run: the claimed job (:func:`drx.queue.dispatch.run_job` records how it ends).
    :return: ``succeeded`` (a stop condition) or ``stopped`` (someone asked, or Ctrl-C), with the
        trainer's result.
    :raises Exception: the training failed; the model's rows past its last checkpoint are gone.
    """
    job, worker_id = run.job, run.worker_id
    with session_scope() as session:
        model = session.get_one(Model, job.model_id)
    forget = reward_guard.on_stuck(lambda sentence: _fail_stuck(job, model, worker_id, sentence))
    try:
        spec = build_spec(job, model)
        spec.started = run.started
        _record_device(job.id, spec.device or "cpu")
        _sync_rows_with_checkpoint(model.id, job.id, spec.folder)
        registry = StoringSink(RegistrySink(model.id, job.id, run.heart), get_store(), model.name)
        shown = run.progress(spec.stop, describe_device(spec.device or "cpu")) if run.progress else None
        with shown or contextlib.nullcontext() as progress:
            extra = [s for s in (run.extra_sink, progress) if s is not None]
            sink: TrainingSink = MultiSink(registry, *extra) if extra else registry
            trial = run.trial_for(job) if run.trial_for else None  # a sweep's trial reports to its study
            if trial is None and (job.options or {}).get("sweep"):
                raise DrxError(
                    f"Job {job.id} is a sweep trial; run it with `drx job run {job.id}` or a `drx worker`, "
                    "which report it to its sweep."
                )
            trainer = Trainer(spec, trial.sink(sink) if trial else sink)
            result = trial.run(trainer) if trial else trainer.run()
    except Exception:
        lifecycle.remove_traces_after_checkpoint(model.name)  # first: on a full disk this frees room
        with contextlib.suppress(Exception):  # the model keeps its last good checkpoint; rows past it go
            _sync_rows_with_checkpoint(model.id, job.id, model_artifacts_dir(model.name))
        raise
    finally:
        forget()
    reason = result.stop_reason or "done"
    status = "stopped" if reason in (REQUESTED, "interrupted") else "succeeded"
    return JobOutcome(status=status, stop_reason=reason, result=result)


def _fail_stuck(job: Job, model: Model, worker_id: str, sentence: str) -> None:
    """The last words of a process ending over a reward call that cannot be interrupted."""
    with contextlib.suppress(Exception):
        _sync_rows_with_checkpoint(model.id, job.id, model_artifacts_dir(model.name))
    lifecycle.fail(job.id, worker_id, sentence)
