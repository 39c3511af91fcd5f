"""``drx job run ID``: the one entrypoint that runs a job of any kind, whoever launches it.

:func:`run_job` claims the job (or checks that the worker that launched it holds
it), looks its runner up by kind in :data:`drx.queue.kinds.KINDS`, beats the job's
heart while the runner works, and records how the job ended through
:mod:`drx.queue.lifecycle`: ``succeeded`` or ``stopped`` (what the runner says),
``failed`` (the error, e.g. the reward function's file, line and params), or back
to ``queued`` when the process is asked to terminate (SIGTERM). Runners only do
their kind's work; no runner changes a job's state itself.
"""

from __future__ import annotations

import contextlib
import importlib
import json
import signal
import time
import traceback
from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass
from types import FrameType
from typing import TYPE_CHECKING, Any, Protocol

from drx.errors import DrxError, Interruption
from drx.queue import lifecycle
from drx.queue.heart import Heart
from drx.queue.kinds import job_kind
from drx.registry import Job
from drx.registry.engine import storage_error
from drx.sim.reward_loader import RewardFunctionError
from drx.train.stop import REQUESTED, StopRequested

if TYPE_CHECKING:
    from drx.settings.stop import StopConditions
    from drx.train.records import TrainingSink
    from drx.train.trainer import Trainer, TrainingResult


class JobTakenError(DrxError):
    """The job is not queued any more (a worker took it, or it ended)."""


class WorkerShutdown(Interruption):
    """The process was asked to terminate (SIGTERM): hand the job back to the queue.

    An :class:`~drx.errors.Interruption`, so that a reward function running at that moment
    (or any ``except Exception``) does not turn it into the job's failure."""


@dataclass
class JobOutcome:
    """How a job ended here.

    :param status: ``succeeded``, ``stopped``, ``failed``, ``queued`` (handed back on SIGTERM) or
        ``lost`` (another worker took over after this one's lease ran out).
    :param stop_reason: why it stopped or succeeded (a training's stop condition, ``evaluation 7``).
    :param error: why it failed.
    :param result: a training job's result.
    :param evaluation_id: an evaluation job's stored evaluation.
    """

    status: str
    stop_reason: str | None = None
    error: str | None = None
    result: TrainingResult | None = None
    evaluation_id: int | None = None


# What the caller shows while a training job runs: given the job's stop conditions and its device
# (drx.train.device.describe_device), a sink used as a context manager (``drx job run``'s plain
# progress lines).
ProgressFactory = Callable[["StopConditions", str], AbstractContextManager["TrainingSink"]]


class TrainingTrial(Protocol):
    """A training job that reports to something above the queue as it runs (a sweep's trial,
    :class:`drx.sweep.trial.SweepTrial`): it wraps the run's sink and runs the trainer."""

    def sink(self, inner: TrainingSink) -> TrainingSink:
        """``inner``, also reporting to the trial's owner."""
        ...

    def run(self, trainer: Trainer) -> TrainingResult:
        """Run ``trainer`` to its end as the trial."""
        ...


# The trial a training job is, or None for an ordinary job. The caller that runs jobs (the CLI's
# `drx job run`, which `drx worker` launches) passes drx.sweep's, so the queue never imports the
# sweep, which queues its trials through the lifecycle.
TrialFinder = Callable[[Job], TrainingTrial | None]


@dataclass
class JobRun:
    """What a runner gets: the claimed job and what the caller adds.

    :param job: the job, claimed by ``worker_id``.
    :param worker_id: who holds it.
    :param heart: its heartbeat (:attr:`stop_requested` reads it).
    :param started: ``time.monotonic()`` when the job started here (a training's ``max_minutes``).
    :param extra_sink: another training sink (``drx train``'s live dashboard).
    :param progress: makes a training's progress display once its stop conditions are known.
    :param trial_for: finds the trial a training job is (see :data:`TrialFinder`).
    """

    job: Job
    worker_id: str
    heart: Heart
    started: float
    extra_sink: TrainingSink | None = None
    progress: ProgressFactory | None = None
    trial_for: TrialFinder | None = None

    def stop_requested(self) -> bool:
        """Whether someone asked the job to stop (``drx jobs stop``) or its lease was lost."""
        return self.heart.stop or self.heart.lost


Runner = Callable[[JobRun], JobOutcome]


def runner_for(kind: str) -> Runner:
    """The function that runs jobs of ``kind`` (imported now: torch and SB3 load here).

    :raises DrxError: an unknown kind.
    """
    module, _, name = job_kind(kind).runner.partition(":")
    runner: Runner = getattr(importlib.import_module(module), name)
    return runner


def run_job(
    job_id: int,
    worker_id: str | None = None,
    extra_sink: TrainingSink | None = None,
    parent_pid: int | None = None,
    started: float | None = None,
    progress: ProgressFactory | None = None,
    trial_for: TrialFinder | None = None,
) -> JobOutcome:
    """Run a job of any kind to its end and record the outcome on the job.

    :param job_id: the job.
    :param worker_id: the worker that already claimed the job; ``None`` to claim it here.
    :param extra_sink: another training sink (the live dashboard), besides the registry.
    :param parent_pid: the launching worker's pid; when it dies this process exits (and the job is
        resumed elsewhere).
    :param started: ``time.monotonic()`` when the job started here; ``None``: now.
    :param progress: makes a training's progress display (see :data:`ProgressFactory`).
    :param trial_for: finds the trial a training job is (a sweep's); a trial run without it fails.
    :raises DrxError: the job cannot run here (not queued, held by another worker, unknown kind);
        a full disk or read-only home (after the job is marked failed).
    """
    started = time.monotonic() if started is None else started
    runner = runner_for(lifecycle.get_job(job_id).kind)  # imports first: nothing is claimed if they fail
    previous = _install_sigterm()  # before the claim: SIGTERM from here on hands the job back
    try:
        worker_id = _hold(job_id, worker_id)
        job = lifecycle.get_job(job_id)
        heart = Heart(job_id, worker_id, job.lease_seconds, parent_pid=parent_pid)
        try:
            heart.beat()  # a stop requested before the job got here is seen at once
            heart.start()
            run = JobRun(
                job, worker_id, heart, started, extra_sink=extra_sink, progress=progress, trial_for=trial_for
            )
            return _record(run, runner)
        finally:
            heart.halt()
    except WorkerShutdown:  # between the claim and the runner: hand the job back as well
        lifecycle.release(job_id, worker_id, reason="its worker was shut down")
        return JobOutcome(status="queued", stop_reason="worker shut down")
    finally:
        _restore_sigterm(previous)


def _hold(job_id: int, worker_id: str | None) -> str:
    """Claim the job for a new worker id, or check that ``worker_id`` holds it; returns the holder."""
    if worker_id is None:
        worker_id = lifecycle.new_worker_id()
        if not lifecycle.claim(job_id, worker_id):
            job = lifecycle.get_job(job_id)
            where = f" on {job.worker_id}" if job.worker_id else ""
            raise JobTakenError(f"Job {job_id} is {job.status}{where}; only a queued job can be run.")
        return worker_id
    job = lifecycle.get_job(job_id)
    if job.status != "running" or job.worker_id != worker_id:
        raise DrxError(f"Job {job_id} is not held by worker {worker_id} (it is {job.status}).")
    return worker_id


def _record(run: JobRun, runner: Runner) -> JobOutcome:
    """Run the runner; every way it can end becomes one state change of the job."""
    job_id, worker_id = run.job.id, run.worker_id
    try:
        outcome = runner(run)
    except WorkerShutdown:
        lifecycle.release(job_id, worker_id, reason="its worker was shut down")
        return JobOutcome(status="queued", stop_reason="worker shut down")
    except StopRequested:  # a runner may let the heart's stop end it (a training handles it itself)
        outcome = JobOutcome(status="stopped", stop_reason=REQUESTED)
    except Exception as exc:
        storage = storage_error(exc)  # a full disk or a read-only home: one sentence, no traceback
        error = str(storage) if storage is not None else format_error(exc)
        lifecycle.fail(job_id, worker_id, error)
        if storage is not None:
            raise storage from None
        return JobOutcome(status="failed", error=error)
    except (KeyboardInterrupt, SystemExit):  # outside a trainer's own Ctrl-C handling
        lifecycle.finish(job_id, worker_id, "stopped", stop_reason="interrupted")
        raise
    if run.heart.lost:  # another worker runs it now: its outcome is that worker's to record
        outcome.status, outcome.stop_reason = "lost", "lease lost to another worker"
        return outcome
    lifecycle.finish(job_id, worker_id, outcome.status, stop_reason=outcome.stop_reason, error=outcome.error)
    return outcome


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
