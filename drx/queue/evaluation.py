"""Evaluations as queued jobs (``drx evaluate --detach``): kind ``evaluate`` in the ``jobs`` table.

:func:`enqueue_evaluation` stores the request as a job's options;
:func:`run_evaluation_job` claims the job (or accepts one a worker already
claimed), races and stores the result with the job's id, and finishes the job.
An evaluation job never changes its model's status (the model is not trained
by it). Like every state change of the queue, claiming and finishing are one
conditional ``UPDATE`` each, so two workers never both run a job.
"""

from __future__ import annotations

from pathlib import Path

from sqlalchemy import update

from drx.errors import DrxError, NotFoundError
from drx.evaluate import service
from drx.evaluate.service import EvaluationRequest
from drx.registry import Job, session_scope, utcnow
from drx.services.models import get_model

KIND = "evaluate"


def enqueue_evaluation(request: EvaluationRequest, video: Path | None = None) -> Job:
    """Queue an evaluation job for ``request`` (checked first with :func:`service.prepare`)."""
    service.prepare(request)
    model = get_model(request.model)
    options = request.to_options()
    if video is not None:
        options["video"] = str(Path(video).expanduser().resolve())
    with session_scope() as session:
        job = Job(model_id=model.id, kind=KIND, status="queued", options=options, max_attempts=1)
        session.add(job)
        session.flush()
        return job


def run_evaluation_job(job_id: int, worker_id: str | None = None, parent_pid: int | None = None) -> int:
    """Run an ``evaluate`` job to its end; returns the stored evaluation's id.

    :param job_id: the job.
    :param worker_id: the worker that already claimed it; ``None`` to claim it here.
    :param parent_pid: the launching worker's pid (``drx job run --parent-pid``); when it dies this
        process exits. The job's heartbeat goes on while it runs, so no worker requeues it.
    :raises DrxError: not an evaluation job, or not runnable here; the job is marked failed when the
        evaluation itself fails.
    """
    with session_scope() as session:
        job = session.get(Job, job_id)
        if job is None:
            raise NotFoundError(f"No job {job_id}; see `drx jobs list`.")
        kind, options, lease = job.kind, dict(job.options or {}), int(job.lease_seconds)
    if kind != KIND:
        raise DrxError(f"Job {job_id} is a {kind} job, not an evaluation.")
    if worker_id is None:
        from drx.queue.lifecycle import new_worker_id

        worker_id = new_worker_id()
        if not _transition(job_id, "queued", {"status": "running", "worker_id": worker_id}, started=True):
            raise DrxError(f"Job {job_id} is not queued; only a queued job can be run.")
    from drx.queue.sink import Heart

    heart = Heart(job_id, worker_id, lease, parent_pid=parent_pid)
    heart.start()
    video = options.pop("video", None)
    try:
        prepared = service.prepare(EvaluationRequest.from_options(options))
        result = service.run(prepared, video=Path(video) if video else None)
        evaluation_id = service.store(prepared, result, job_id=job_id, video=Path(video) if video else None)
    except BaseException as exc:
        _transition(job_id, "running", {"status": "failed", "error": str(exc) or type(exc).__name__})
        raise
    finally:
        heart.halt()
    _transition(job_id, "running", {"status": "succeeded", "stop_reason": f"evaluation {evaluation_id}"})
    return evaluation_id


def _transition(job_id: int, expected: str, values: dict[str, object], started: bool = False) -> bool:
    """``UPDATE jobs SET values WHERE id = job_id AND status = expected``; whether it changed the row."""
    now = utcnow()
    values = dict(values)
    if started:
        values.update(started_at=now, heartbeat_at=now, attempts=Job.attempts + 1)
    if values.get("status") in ("succeeded", "failed"):
        values["finished_at"] = now
    with session_scope() as session:
        result = session.execute(
            update(Job)
            .where(Job.id == job_id, Job.status == expected)
            .values(**values)
            .execution_options(synchronize_session=False)
        )
        return result.rowcount == 1  # type: ignore[attr-defined]
