"""``drx job run ID``: the one entrypoint that runs a job, whoever launches it.

It claims the job (or checks that the worker that launched it holds it),
builds the trainer from the model's registry row, resumes from the model's last
checkpoint when one exists (a clone starts from its parent's best), beats its
heart while training, and records how the job ended: ``succeeded`` (a stop
condition), ``stopped`` (someone asked, or Ctrl-C) or ``failed`` (with the
error, e.g. the reward function's file, line and params).
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import time
import traceback
from dataclasses import dataclass
from pathlib import Path
from types import FrameType
from typing import Any

import gymnasium as gym
from sqlalchemy import select

from drx.errors import DrxError, Interruption, not_a_file
from drx.queue import jobs
from drx.queue.sink import Heart, RegistrySink, truncate_after
from drx.registry import Checkpoint, Job, Model, RewardSource, session_scope
from drx.registry.engine import storage_error
from drx.services.models import model_artifacts_dir
from drx.services.rewards import check_trusted
from drx.services.tracks import resolve_track_path
from drx.sim import reward_guard
from drx.sim.reward_loader import RewardFunctionError
from drx.storage import get_store
from drx.storage.base import MODEL_FILES
from drx.sweep.trial import SweepTrial
from drx.train.checkpoint import checkpoint_path, read_meta
from drx.train.hyperparameters import Hyperparameters
from drx.train.records import MultiSink, TrainingSink
from drx.train.rollout import default_rollout_workers
from drx.train.stop import REQUESTED, StopConditions
from drx.train.storing_sink import StoringSink
from drx.train.trainer import Trainer, TrainingResult, TrainingSpec

STOP_KEYS = ("max_minutes", "max_steps", "max_episodes", "target_iterations")


class JobTakenError(DrxError):
    """The job is not queued any more (a worker took it, or it ended)."""


class WorkerShutdown(Interruption):
    """The process was asked to terminate (SIGTERM): hand the job back to the queue.

    An :class:`~drx.errors.Interruption`, so that a reward function running at that moment
    (or any ``except Exception``) does not turn it into the job's failure."""


@dataclass
class JobOutcome:
    """How ``run_job`` ended: the job's final status, the stop reason or error, the trainer's result."""

    status: str
    stop_reason: str | None = None
    error: str | None = None
    result: TrainingResult | None = None


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
    """Where a model with no checkpoint of its own starts: ``--checkpoint``, else its parent's best."""
    given = options.get("checkpoint")
    if given:
        path = Path(given).expanduser()
        if not path.is_file():
            raise not_a_file(given, "--checkpoint", "give a checkpoint .zip file")
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
    stop_values = {
        **(model.stop_conditions or {}),
        **{k: v for k, v in ((job.options or {}).get("stop") or {}).items() if v},
    }
    return StopConditions.from_dict({k: stop_values.get(k) for k in STOP_KEYS})


def build_spec(job: Job, model: Model) -> TrainingSpec:
    """The trainer's :class:`TrainingSpec` for a job of a model."""
    options = dict(job.options or {})
    vehicle = model.vehicle()
    race = dict(model.race or {})
    randomize = bool(model.domain_randomization)
    hp = Hyperparameters.from_dict(model.hyperparameters, algorithm=model.algorithm)
    stop = stop_conditions_for(job, model)
    folder = model_artifacts_dir(model.name)
    get_store().pull_tree(model.name, MODEL_FILES)  # another host may have trained it last
    track_path, _ = resolve_track_path(model.track_name)
    reward_path = _reward_file(folder, model)
    has_own = checkpoint_path(folder, "last").is_file()
    if has_own and options.get("checkpoint"):
        raise DrxError(
            f"Model {model.name!r} already has checkpoints, so training continues from its last one; "
            "--checkpoint applies only to a model's first training (clone the model to start elsewhere)."
        )
    init = None if has_own else _init_checkpoint(model, options)

    extra_params: dict[str, Any] = {}  # computed with the first env, shared by the job's envs

    def make_env(mode: str) -> gym.Env:
        from drx.evaluate.best_lap import PARAMS_KEY, racing_line_waypoints
        from drx.sim.registration import ENV_ID, register_envs
        from drx.sim.track import load_track
        from drx.watch.live import LivePoseWriter

        register_envs()
        if not extra_params:  # params["racing_line"] for reward functions (~0.1-1 s, once per job)
            extra_params[PARAMS_KEY] = racing_line_waypoints(load_track(track_path))
        env = gym.make(
            ENV_ID,
            track=str(track_path),
            vehicle=vehicle,
            reward_function=str(reward_path),
            mode=mode,
            race=race,  # boxes or bots of an object-avoidance / head-to-bot model
            domain_randomization=randomize and mode == "training",  # evaluations see the usual look
            extra_params=extra_params,
            disable_env_checker=True,
        )
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
            or model.rollout_workers
            or default_rollout_workers(torch_threads())
        ),
    )


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


def format_error(exc: BaseException) -> str:
    """The sentence stored on a failed job; a reward error adds its params (without the long lists)."""
    if isinstance(exc, RewardFunctionError):
        text = str(exc)
        if exc.params:
            shown = {
                k: (f"<{len(v)} items>" if isinstance(v, list | tuple) and len(v) > 4 else v)
                for k, v in exc.params.items()
            }
            text += "\nparams: " + json.dumps(shown, default=str)
        return text
    if isinstance(exc, DrxError):
        return str(exc)
    tb = traceback.format_exception(type(exc), exc, exc.__traceback__)
    return f"{type(exc).__name__}: {exc}\n" + "".join(tb[-6:])


def run_job(
    job_id: int,
    worker_id: str | None = None,
    extra_sink: TrainingSink | None = None,
    parent_pid: int | None = None,
    started: float | None = None,
) -> JobOutcome:
    """Run a training job to its end and record the outcome on the job.

    :param job_id: the job.
    :param worker_id: the worker that already claimed the job; ``None`` to claim it here.
    :param extra_sink: another sink (the live dashboard), besides the registry.
    :param parent_pid: the launching worker's pid; when it dies this process exits (and the job is resumed).
    :param started: ``time.monotonic()`` when the job started here (``max_minutes`` counts from it);
        ``None``: now.
    :raises DrxError: the job cannot run here (not queued, held by another worker...).
    """
    started = time.monotonic() if started is None else started
    job = jobs.get_job(job_id)
    if worker_id is None:
        worker_id = jobs.new_worker_id()
        if not jobs.claim(job_id, worker_id):
            job = jobs.get_job(job_id)
            where = f" on {job.worker_id}" if job.worker_id else ""
            raise JobTakenError(f"Job {job_id} is {job.status}{where}; only a queued job can be run.")
    elif job.status != "running" or job.worker_id != worker_id:
        raise DrxError(f"Job {job_id} is not held by worker {worker_id} (it is {job.status}).")
    job = jobs.get_job(job_id)
    with session_scope() as session:
        model = session.get_one(Model, job.model_id)
    heart = Heart(job_id, worker_id, job.lease_seconds, parent_pid=parent_pid)
    heart.start()
    previous = _install_sigterm()
    forget = reward_guard.on_stuck(lambda sentence: _fail_stuck(job, model, worker_id, sentence))
    try:
        return _run(job, model, worker_id, heart, extra_sink, started)
    finally:
        forget()
        heart.halt()
        _restore_sigterm(previous)


def _fail_stuck(job: Job, model: Model, worker_id: str, sentence: str) -> None:
    """The last words of a process ending over a reward call that cannot be interrupted."""
    with contextlib.suppress(Exception):
        _sync_rows_with_checkpoint(model.id, job.id, model_artifacts_dir(model.name))
    jobs.finish(job.id, worker_id, "failed", error=sentence)


def _run(
    job: Job, model: Model, worker_id: str, heart: Heart, extra_sink: TrainingSink | None, started: float
) -> JobOutcome:
    try:
        spec = build_spec(job, model)
        spec.started = started
        _sync_rows_with_checkpoint(model.id, job.id, spec.folder)
        registry = StoringSink(RegistrySink(model.id, job.id, heart), get_store(), model.name)
        sink = MultiSink(registry, extra_sink) if extra_sink is not None else registry
        trial = SweepTrial.of(job)  # a sweep trial reports each iteration to its study (drx.sweep)
        trainer = Trainer(spec, trial.sink(sink) if trial else sink)
        result = trial.run(trainer) if trial else trainer.run()
    except WorkerShutdown:
        jobs.release(job.id, worker_id, reason="its worker was shut down")
        return JobOutcome(status="queued", stop_reason="worker shut down")
    except Exception as exc:
        storage = storage_error(exc)  # a full disk or a read-only home: one sentence, no traceback
        error = str(storage) if storage is not None else format_error(exc)
        jobs.remove_traces_after_checkpoint(model.name)  # first: on a full disk this frees room
        with contextlib.suppress(Exception):  # the model keeps its last good checkpoint; rows past it go
            _sync_rows_with_checkpoint(model.id, job.id, model_artifacts_dir(model.name))
        jobs.finish(job.id, worker_id, "failed", error=error)
        if storage is not None:
            raise storage from None
        return JobOutcome(status="failed", error=error)
    except (KeyboardInterrupt, SystemExit):  # outside the trainer's loop (building it): nothing ran
        jobs.finish(job.id, worker_id, "stopped", stop_reason="interrupted")
        raise
    if heart.lost:
        return JobOutcome(status="lost", stop_reason="lease lost to another worker", result=result)
    reason = result.stop_reason or "done"
    status = "stopped" if reason in (REQUESTED, "interrupted") else "succeeded"
    jobs.finish(job.id, worker_id, status, stop_reason=reason)
    return JobOutcome(status=status, stop_reason=reason, result=result)


def _restore_sigterm(previous: Any) -> None:
    with contextlib.suppress(ValueError, TypeError):  # not the main thread, or no previous handler
        signal.signal(signal.SIGTERM, previous)


def _install_sigterm() -> Any:
    def handler(signum: int, frame: FrameType | None) -> None:
        raise WorkerShutdown()

    try:
        return signal.signal(signal.SIGTERM, handler)
    except ValueError:  # not the main thread
        return signal.SIG_DFL
