"""``drx worker``: runs queued jobs, each in its own ``drx job run ID`` process.

The worker claims the oldest queued job (atomically, see :mod:`drx.queue.lifecycle`)
whenever it has a free slot, launches ``drx job run ID`` for it with torch
limited to ``cores / (concurrency + jobs of other workers on this machine)``
threads, and requeues jobs whose worker went
silent. A job's process dies with its worker (Linux: ``PR_SET_PDEATHSIG``;
elsewhere the job notices its parent is gone), so a killed worker's job goes
back to the queue when its lease runs out and the next worker resumes it from
its last checkpoint.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from drx.queue import lifecycle
from drx.registry import session_scope
from drx.registry.job_rows import Job
from drx.services.models import model_artifacts_dir
from drx.settings.device import DEVICE_ENV

POLL_SECONDS = 1.0


def available_cores() -> int:
    """CPU cores this process may run on."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:
        return max(1, os.cpu_count() or 1)


def threads_per_job(concurrency: int, other_jobs: int = 0) -> int:
    """Torch threads for each of ``concurrency`` jobs, so that together they use the cores once.

    :param concurrency: this worker's job slots.
    :param other_jobs: jobs other workers on this machine are running (they share the cores).
    ``$DRX_TORCH_THREADS`` in the worker's environment sets it explicitly.
    """
    explicit = os.environ.get("DRX_TORCH_THREADS")
    if explicit:
        return max(1, int(explicit))
    return max(1, available_cores() // max(1, concurrency + other_jobs))


def jobs_of_other_workers_here(worker_id: str) -> int:
    """Running jobs held by other workers on this host (worker ids are ``host:pid``)."""
    from sqlalchemy import func, select

    host = worker_id.rsplit(":", 1)[0]
    with session_scope() as session:
        count = session.scalar(
            select(func.count(Job.id)).where(
                Job.status == "running", Job.worker_id.startswith(f"{host}:"), Job.worker_id != worker_id
            )
        )
    return int(count or 0)


def _die_with_parent() -> None:  # pragma: no cover - runs in the child
    """In the child before exec: get SIGKILL when the worker dies (Linux)."""
    try:
        libc = ctypes.CDLL("libc.so.6", use_errno=True)
        libc.prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    except OSError:
        pass


def _store_log(log_path: Path) -> None:
    """Store a finished job's log with its model's files (a bucket: readable from any host)."""
    from drx.errors import DrxError
    from drx.storage import get_store

    name = log_path.parent.parent.name  # <models>/<name>/logs/job-<id>.log
    with contextlib.suppress(DrxError, OSError):
        get_store().push(name, f"logs/{log_path.name}")


@dataclass
class Running:
    """A job process the worker launched."""

    job_id: int
    process: subprocess.Popen[bytes]
    log_path: Path


@dataclass
class Worker:
    """Runs queued jobs with at most ``concurrency`` at a time.

    :param concurrency: jobs run at once.
    :param worker_id: how this worker names itself on the jobs it holds.
    :param poll_seconds: how often it looks at the queue.
    :param exit_when_idle: return once the queue is empty and no job runs (tests, batch use).
    :param on_event: called with a line of text for each thing that happens.
    :param device: the torch device for the training jobs it runs (``$DRX_DEVICE`` in their
        environment, :func:`drx.settings.device.job_device`: a job's own ``--device`` beats it, it
        beats the model's); ``None``: each job's or model's, else auto.
    """

    concurrency: int = 1
    worker_id: str = field(default_factory=lifecycle.new_worker_id)
    poll_seconds: float = POLL_SECONDS
    exit_when_idle: bool = False
    on_event: Callable[[str], None] = print
    device: str | None = None
    running: dict[int, Running] = field(default_factory=dict)
    _stopping: bool = False

    def launch(self, job: Job) -> Running:
        """Start ``drx job run ID`` for a job this worker has claimed."""
        with session_scope() as session:
            from drx.registry import Model

            model_name = session.get_one(Model, job.model_id).name
            row = session.get_one(Job, job.id)
            log_path = model_artifacts_dir(model_name) / "logs" / f"job-{job.id}.log"
            row.log_path = str(log_path)
        log_path.parent.mkdir(parents=True, exist_ok=True)
        env = dict(os.environ)
        threads = threads_per_job(self.concurrency, jobs_of_other_workers_here(self.worker_id))
        env["DRX_TORCH_THREADS"] = str(threads)
        env["OMP_NUM_THREADS"] = env["DRX_TORCH_THREADS"]
        # Idle OpenMP threads sleep instead of spinning: on a busy machine spinning threads
        # slow training several-fold (measured: 2 spinning threads at load 8 on 2 cores ran
        # 3-10x slower than 1 thread; sleeping ones about 2x).
        env.setdefault("OMP_WAIT_POLICY", "PASSIVE")
        if self.device is not None:
            env[DEVICE_ENV] = self.device
        cmd = [
            sys.executable,
            "-m",
            "drx.cli.main",
            "job",
            "run",
            str(job.id),
            "--claimed-by",
            self.worker_id,
            "--parent-pid",
            str(os.getpid()),
        ]
        with log_path.open("ab") as log:
            process = subprocess.Popen(
                cmd,
                stdout=log,
                stderr=subprocess.STDOUT,
                stdin=subprocess.DEVNULL,
                env=env,
                preexec_fn=_die_with_parent if sys.platform.startswith("linux") else None,
                start_new_session=True,  # Ctrl-C in a terminal reaches only the worker: it hands jobs back
            )
        self.on_event(
            f"job {job.id} ({model_name}) started, pid {process.pid}, {threads} thread(s), log {log_path}"
        )
        return Running(job.id, process, log_path)

    def reap(self) -> None:
        """Collect finished job processes; a job left ``running`` by a crashed process is released."""
        for job_id, run in list(self.running.items()):
            code = run.process.poll()
            if code is None:
                continue
            del self.running[job_id]
            job = lifecycle.get_job(job_id)
            if job.status == "running" and job.worker_id == self.worker_id:
                lifecycle.release(job_id, self.worker_id, reason=f"its process exited with code {code}")
                job = lifecycle.get_job(job_id)
            _store_log(run.log_path)
            detail = job.stop_reason or next(iter((job.error or "").splitlines()), "")
            self.on_event(f"job {job_id} {job.status}" + (f": {detail}" if detail else ""))

    def beat(self) -> None:
        """Heartbeats for the job processes still alive (they also beat once started).

        A job process needs seconds to import torch and build its model before its own
        heartbeat starts; the worker covers that time, and any time the job is busy.
        """
        for job_id, run in self.running.items():
            if run.process.poll() is None:
                lifecycle.heartbeat(job_id, self.worker_id)

    def step(self) -> None:
        """One round: beat for live jobs, requeue silent ones, reap finished ones, fill free slots."""
        self.beat()
        for job_id in lifecycle.requeue_expired():
            self.on_event(f"job {job_id}: its worker went silent; back on the queue")
        self.reap()
        while not self._stopping and len(self.running) < self.concurrency:
            job = lifecycle.claim_next(self.worker_id)
            if job is None:
                break
            self.running[job.id] = self.launch(job)

    def run(self) -> None:
        """Run until interrupted (or, with ``exit_when_idle``, until there is nothing left to do)."""
        previous = signal.signal(signal.SIGTERM, self._terminate)
        on = f", training on {self.device}" if self.device is not None else ""
        self.on_event(
            f"worker {self.worker_id}: up to {self.concurrency} job(s), "
            f"{threads_per_job(self.concurrency)} torch thread(s) each{on}"
        )
        try:
            while True:
                self.step()
                if self._stopping and not self.running:
                    return
                if self.exit_when_idle and not self.running and not self._queue_has_work():
                    return
                time.sleep(self.poll_seconds)
        except KeyboardInterrupt:
            self.on_event("stopping: jobs go back to the queue")
            self.shutdown()
        finally:
            signal.signal(signal.SIGTERM, previous)

    def _terminate(self, signum: int, frame: object) -> None:
        raise KeyboardInterrupt

    def shutdown(self, timeout: float = 60.0) -> None:
        """Ask running jobs to hand themselves back (SIGTERM) and wait for them."""
        self._stopping = True
        for run in self.running.values():
            if run.process.poll() is None:
                run.process.send_signal(signal.SIGTERM)
        deadline = time.monotonic() + timeout
        for run in self.running.values():
            try:
                run.process.wait(max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                run.process.kill()
        self.reap()

    def _queue_has_work(self) -> bool:
        from sqlalchemy import select

        with session_scope() as session:
            return (
                session.scalar(select(Job.id).where(Job.status.in_(("queued", "running"))).limit(1))
                is not None
            )
