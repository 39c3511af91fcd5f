"""The job queue's lifecycle: enqueue, claim, heartbeat, requeue, finish, stop.

Jobs live in the registry's ``jobs`` table. Every state change is one
conditional ``UPDATE ... WHERE status = <expected>`` through SQLAlchemy Core,
and the caller checks how many rows it changed: two workers racing for the
same job both run the UPDATE, exactly one changes a row. Nothing here relies on
SQLite (no ``BEGIN IMMEDIATE`` tricks, no ``RETURNING``), so the same code runs
against PostgreSQL.

Lifecycle, the same for every kind of job (:mod:`drx.queue.kinds`): ``queued`` ->
``running`` -> ``succeeded`` | ``stopped`` | ``failed``; a queued job that is stopped
becomes ``cancelled``. A ``running`` job whose heartbeat is older than its lease, or
whose worker was shut down, goes back to ``queued`` (a training job's next attempt
resumes from the last checkpoint, an evaluation starts over) while
``attempts < max_attempts``, else it fails. Only kinds that train their model
(``trains_model``) move the model's status, in the same transaction as the job's.
"""

from __future__ import annotations

import contextlib
import json
import os
import socket
import zipfile
from dataclasses import dataclass
from datetime import datetime, timedelta
from typing import Any

from sqlalchemy import delete, select, update
from sqlalchemy.orm import Session

from drx.errors import DrxError, NotFoundError
from drx.queue.kinds import KINDS, job_kind, trains_model
from drx.registry import (
    JOB_ACTIVE_STATUSES,
    Checkpoint,
    Episode,
    IterationMetric,
    Job,
    Model,
    session_scope,
    utcnow,
)
from drx.services.models import get_model, model_artifacts_dir, set_status
from drx.storage import get_store

DEFAULT_LEASE_SECONDS = 60  # a job whose worker is silent this long is requeued


def lease_seconds_default() -> int:
    """The lease for new jobs: ``$DRX_JOB_LEASE_SECONDS`` or 60 s."""
    return int(os.environ.get("DRX_JOB_LEASE_SECONDS") or DEFAULT_LEASE_SECONDS)


def new_worker_id() -> str:
    """``host:pid``, naming this process as the holder of a job."""
    return f"{socket.gethostname()}:{os.getpid()}"


def holder_is_dead(worker_id: str | None) -> bool:
    """Whether ``host:pid`` names a process of this host that no longer exists."""
    if not worker_id or ":" not in worker_id:
        return False
    host, _, pid = worker_id.rpartition(":")
    if host != socket.gethostname() or not pid.isdigit():
        return False
    try:
        os.kill(int(pid), 0)
    except ProcessLookupError:
        return True
    except OSError:  # exists, owned by someone else
        return False
    return False


def release_dead_holders(model_id: int | None = None) -> list[int]:
    """Requeue (or fail) running jobs whose holding process on this host has died, without
    waiting for their lease (e.g. a foreground ``drx train`` that died on a database error)."""
    with session_scope() as session:
        query = select(Job).where(Job.status == "running")
        if model_id is not None:
            query = query.where(Job.model_id == model_id)
        running = list(session.scalars(query))
    return [
        job.id
        for job in running
        if holder_is_dead(job.worker_id)
        and release(
            job.id,
            job.worker_id,
            reason=f"its process ({job.worker_id}) died; a new job resumes from the last checkpoint",
            give_up=True,
        )
    ]


def enqueue_training(model_name: str, options: dict[str, Any] | None = None) -> Job:
    """Queue a training job for a model.

    :param model_name: the model to train.
    :param options: job settings: ``stop`` (stop-condition overrides), ``checkpoint``, ``seed``...
    :raises DrxError: the model already has a queued or running training job (evaluations do not count).
    """
    model = get_model(model_name)
    get_store().check()  # a job whose checkpoints cannot be stored is not queued
    release_dead_holders(model.id)
    with session_scope() as session:
        training = [name for name, kind in KINDS.items() if kind.trains_model]  # queued evaluations may wait
        active = session.scalar(
            select(Job)
            .where(Job.model_id == model.id, Job.kind.in_(training), Job.status.in_(JOB_ACTIVE_STATUSES))
            .limit(1)
        )
        if active is not None:
            raise DrxError(
                f"Model {model_name!r} already has job {active.id} {active.status}; "
                f"wait for it or stop it with `drx jobs stop {active.id}`."
            )
        return enqueue(session, model.id, "train", options)


def enqueue(session: Session, model_id: int, kind: str, options: dict[str, Any] | None = None) -> Job:
    """Add a queued job of ``kind`` for a model (inside ``session``); the checks are the caller's.

    :raises DrxError: an unknown kind.
    """
    spec = job_kind(kind)
    job = Job(
        model_id=model_id,
        kind=spec.name,
        status="queued",
        options=dict(options or {}),
        lease_seconds=lease_seconds_default(),
        max_attempts=spec.max_attempts,
    )
    session.add(job)
    session.flush()
    if spec.trains_model:
        set_status(session, model_id, "queued")
    return job


def get_job(job_id: int) -> Job:
    """A job by id.

    :raises NotFoundError: no such job.
    """
    with session_scope() as session:
        job = session.get(Job, job_id)
        if job is None:
            raise NotFoundError(f"No job {job_id}; see `drx jobs list`.")
        return job


def claim(job_id: int, worker_id: str) -> bool:
    """Take a queued job: ``queued`` -> ``running`` for ``worker_id``, atomically.

    :return: whether this call took it (False when another worker did, or it is not queued).
    """
    now = utcnow()
    with session_scope() as session:
        result = session.execute(
            update(Job)
            .where(Job.id == job_id, Job.status == "queued")
            .values(
                status="running",
                worker_id=worker_id,
                started_at=now,
                heartbeat_at=now,
                attempts=Job.attempts + 1,
                stop_requested=False,
            )
            .execution_options(synchronize_session=False)
        )
        if result.rowcount != 1:  # type: ignore[attr-defined]
            return False
        model_id, kind = session.execute(select(Job.model_id, Job.kind).where(Job.id == job_id)).one()
        if model_id is not None and trains_model(kind):
            set_status(session, model_id, "training")
        return True


def claim_next(worker_id: str, kind: str | None = None) -> Job | None:
    """Claim the oldest queued job of ``kind`` (default: any kind of :data:`~drx.queue.kinds.KINDS`);
    ``None`` if none."""
    kinds = tuple(KINDS) if kind is None else (kind,)
    for _ in range(20):  # each loss of a race moves on to the next candidate
        with session_scope() as session:
            candidates = list(
                session.scalars(
                    select(Job.id)
                    .where(Job.status == "queued", Job.kind.in_(kinds))
                    .order_by(Job.created_at, Job.id)
                    .limit(5)
                )
            )
        if not candidates:
            return None
        for job_id in candidates:
            if claim(job_id, worker_id):
                return get_job(job_id)
    return None


@dataclass
class Beat:
    """What a heartbeat learned.

    :param held: the job is still running under this worker (False: the lease was lost).
    :param stop_requested: someone asked the job to stop.
    """

    held: bool
    stop_requested: bool


def heartbeat(job_id: int, worker_id: str) -> Beat:
    """Refresh a running job's heartbeat; says whether the job is still ours and whether to stop."""
    with session_scope() as session:
        result = session.execute(
            update(Job)
            .where(Job.id == job_id, Job.status == "running", Job.worker_id == worker_id)
            .values(heartbeat_at=utcnow())
            .execution_options(synchronize_session=False)
        )
        held = result.rowcount == 1  # type: ignore[attr-defined]
        stop = bool(session.scalar(select(Job.stop_requested).where(Job.id == job_id)))
        return Beat(held=held, stop_requested=stop)


def _expired(job: Job, now: datetime) -> bool:
    beat = job.heartbeat_at or job.started_at or job.created_at
    return beat + timedelta(seconds=job.lease_seconds) < now


def requeue_expired(now: datetime | None = None) -> list[int]:
    """Requeue running jobs whose heartbeat is older than their lease (or fail them past max attempts).

    :return: ids of jobs requeued or failed.
    """
    now = now or utcnow()
    with session_scope() as session:
        running = list(session.scalars(select(Job).where(Job.status == "running")))
    changed = []
    for job in running:
        if _expired(job, now) and release(
            job.id, job.worker_id, job.heartbeat_at, reason="its worker went silent"
        ):
            changed.append(job.id)
    return changed


def release(
    job_id: int,
    worker_id: str | None,
    heartbeat_at: datetime | None = None,
    reason: str = "its worker stopped",
    give_up: bool = False,
) -> bool:
    """Put a running job back on the queue (or fail it when it has used its attempts, or ``give_up``).

    Conditional on the job still being held by ``worker_id`` (and, when given, on its
    heartbeat not having moved), so a live worker's job is never taken from it.

    :return: whether this call changed the job.
    """
    with session_scope() as session:
        job = session.get(Job, job_id)
        if job is None or job.status != "running":
            return False
        conditions = [Job.id == job_id, Job.status == "running", Job.worker_id == worker_id]
        if heartbeat_at is not None:
            conditions.append(Job.heartbeat_at == heartbeat_at)
        final = give_up or job.attempts >= job.max_attempts
        entry = _attempt(job, "failed" if final else "requeued", reason)
        if final:
            values: dict[str, Any] = {
                "status": "failed",
                "finished_at": utcnow(),
                "error": f"{reason[0].upper()}{reason[1:]}."
                if give_up
                else f"Gave up after {job.attempts} attempts: {reason}.",
            }
        else:
            values = {"status": "queued", "worker_id": None, "heartbeat_at": None}
        values["attempt_log"] = [*(job.attempt_log or []), entry]
        result = session.execute(
            update(Job).where(*conditions).values(**values).execution_options(synchronize_session=False)
        )
        if result.rowcount != 1:  # type: ignore[attr-defined]
            return False
        if trains_model(job.kind):
            _truncate_to_checkpoint(session, job.model_id)  # in the same transaction as the new state
            set_status(session, job.model_id, "failed" if values["status"] == "failed" else "queued")
        return True


def _attempt(job: Job, ended: str, reason: str | None) -> dict[str, Any]:
    """One entry of ``jobs.attempt_log``."""
    return {
        "attempt": job.attempts,
        "worker": job.worker_id,
        "ended": ended,
        "reason": (reason or "")[:500],
        "at": utcnow().isoformat(timespec="seconds"),
    }


def last_checkpoint_iteration(model_name: str) -> int:
    """The iteration of the model's stored ``last.zip`` (-1 without one), read from its ``drx.json``.

    With a bucket for artifacts the stored one may come from another host: it is fetched first
    (unless this host's copy is already it); when the bucket cannot be reached this host's copy decides.
    """
    with contextlib.suppress(DrxError):
        get_store().pull(model_name, "model/last.zip")
    path = model_artifacts_dir(model_name) / "model" / "last.zip"
    try:
        with zipfile.ZipFile(path) as zf:
            return int(json.loads(zf.read("drx.json")).get("iteration", -1))
    except (OSError, KeyError, ValueError, zipfile.BadZipFile):
        return -1


def _truncate_to_checkpoint(session: Session, model_id: int) -> None:
    """Delete the model's rows of iterations after its last checkpoint on disk (inside ``session``),
    and the traces of those iterations."""
    name = session.scalar(select(Model.name).where(Model.id == model_id))
    if name is None:
        return
    iteration = remove_traces_after_checkpoint(name)
    for table in (Episode, IterationMetric, Checkpoint):
        session.execute(
            delete(table)
            .where(table.model_id == model_id, table.iteration > iteration)
            .execution_options(synchronize_session=False)
        )


def remove_traces_after_checkpoint(model_name: str) -> int:
    """Delete the training traces of iterations after the model's last checkpoint (they also
    free space on a full disk); returns that checkpoint's iteration (-1 without one)."""
    iteration = last_checkpoint_iteration(model_name)
    traces = model_artifacts_dir(model_name) / "training-simtrace"
    if traces.is_dir():
        for csv in traces.glob("*-iteration.csv"):
            number = csv.name.split("-", 1)[0]
            if number.isdigit() and int(number) > iteration:
                with contextlib.suppress(OSError):
                    csv.unlink()
    store = get_store()
    if store.remote:  # traces a host stored before it died short of storing their checkpoint
        with contextlib.suppress(DrxError):
            stored = store.listing(model_name, "training-simtrace")
            numbers = {r: r.split("/")[-1].split("-", 1)[0] for r in stored}
            late = [r for r, n in numbers.items() if n.isdigit() and int(n) > iteration]
            store.delete(model_name, *late)
    return iteration


def finish(
    job_id: int, worker_id: str, status: str, stop_reason: str | None = None, error: str | None = None
) -> bool:
    """End a running job held by ``worker_id`` as ``succeeded``, ``stopped`` or ``failed``.

    A job that trains its model also sets the model's status: ``ready`` when it has a checkpoint,
    else ``stopped`` / ``failed``.
    """
    assert status in ("succeeded", "stopped", "failed"), f"finish() takes a final status, not {status!r}"
    with session_scope() as session:
        job = session.get(Job, job_id)
        if job is None:
            return False
        log = [*(job.attempt_log or []), _attempt(job, status, error or stop_reason)]
        result = session.execute(
            update(Job)
            .where(Job.id == job_id, Job.status == "running", Job.worker_id == worker_id)
            .values(
                status=status, stop_reason=stop_reason, error=error, finished_at=utcnow(), attempt_log=log
            )
            .execution_options(synchronize_session=False)
        )
        if result.rowcount != 1:  # type: ignore[attr-defined]
            return False
        model_id, kind = job.model_id, job.kind
        if not trains_model(kind):
            return True
        _truncate_to_checkpoint(session, model_id)  # in the same transaction as the final state
        has_checkpoint = session.scalar(select(Checkpoint.id).where(Checkpoint.model_id == model_id).limit(1))
        if status == "failed":
            set_status(session, model_id, "failed")  # type: ignore[arg-type]
        else:
            set_status(session, model_id, "ready" if has_checkpoint is not None else "stopped")  # type: ignore[arg-type]
        return True


def fail(job_id: int, worker_id: str, error: str) -> bool:
    """End a running job held by ``worker_id`` as ``failed`` with ``error`` (see :func:`finish`)."""
    return finish(job_id, worker_id, "failed", error=error)


def request_stop(job_id: int) -> str:
    """Stop a job: a queued one is cancelled at once, a running one stops at its next step.

    :return: the job's status after the request (``cancelled``, ``running``, or a final status).
    """
    with session_scope() as session:
        job = session.get(Job, job_id)
        if job is None:
            raise NotFoundError(f"No job {job_id}; see `drx jobs list`.")
        result = session.execute(
            update(Job)
            .where(Job.id == job_id, Job.status == "queued")
            .values(status="cancelled", finished_at=utcnow(), stop_reason="cancelled before it started")
            .execution_options(synchronize_session=False)
        )
        if result.rowcount == 1 and not trains_model(job.kind):  # type: ignore[attr-defined]
            return "cancelled"
        if result.rowcount == 1:  # type: ignore[attr-defined]
            has_checkpoint = session.scalar(
                select(Checkpoint.id).where(Checkpoint.model_id == job.model_id).limit(1)
            )
            set_status(session, job.model_id, "ready" if has_checkpoint is not None else "draft")
            return "cancelled"
        session.execute(
            update(Job)
            .where(Job.id == job_id, Job.status == "running")
            .values(stop_requested=True)
            .execution_options(synchronize_session=False)
        )
        return str(session.scalar(select(Job.status).where(Job.id == job_id)))


def list_jobs(
    status: str | None = None, model_name: str | None = None, limit: int = 50
) -> list[tuple[Job, str]]:
    """Recent jobs (newest first) with their model's name."""
    with session_scope() as session:
        query = select(Job, Model.name).join(Model, Model.id == Job.model_id)
        if status:
            query = query.where(Job.status == status)
        if model_name:
            query = query.where(Model.name == model_name)
        rows = session.execute(query.order_by(Job.id.desc()).limit(limit)).all()
        return [(job, name) for job, name in rows]
