"""The ``evaluate`` job (``drx evaluate --detach``): its options and its runner.

:func:`enqueue_evaluation` checks the request and queues it as a job's options;
:func:`run_evaluation` is the kind's runner (:data:`drx.queue.kinds.KINDS`): it
races the request and stores the result with the job's id. The job's states
change only through :func:`drx.queue.dispatch.run_job`, as a training job's do:
SIGTERM hands it back to the queue (it starts over, nothing was stored), and
``drx jobs stop`` ends it at its next step as ``stopped``, storing nothing. An
evaluation never changes its model's status (the model is not trained by it).
"""

from __future__ import annotations

from pathlib import Path

from drx.evaluate import service
from drx.evaluate.service import EvaluationRequest
from drx.evaluate.time_trial import StepView
from drx.queue import lifecycle
from drx.queue.dispatch import JobOutcome, JobRun
from drx.registry import Job, session_scope
from drx.services.models import get_model
from drx.train.stop import StopRequested

KIND = "evaluate"


def enqueue_evaluation(request: EvaluationRequest, video: Path | None = None) -> Job:
    """Queue an evaluation job for ``request`` (checked first with :func:`service.prepare`)."""
    service.prepare(request)
    model = get_model(request.model)
    options = request.to_options()
    if video is not None:
        options["video"] = str(Path(video).expanduser().resolve())
    with session_scope() as session:
        return lifecycle.enqueue(session, model.id, KIND, options)


def run_evaluation(run: JobRun) -> JobOutcome:
    """The runner of ``evaluate`` jobs: race the job's request and store the result.

    :param run: the claimed job.
    :return: ``succeeded`` with the stored evaluation's id.
    :raises StopRequested: the job was asked to stop (or lost its lease) during the race.
    """
    options = dict(run.job.options or {})
    video = options.pop("video", None)
    clip = Path(video) if video else None

    def watch_stop(view: StepView) -> None:  # after every step: a stop request ends the race here
        if run.stop_requested():
            raise StopRequested()

    prepared = service.prepare(EvaluationRequest.from_options(options))
    result = service.run(prepared, observer=watch_stop, video=clip)
    evaluation_id = service.store(prepared, result, job_id=run.job.id, video=clip)
    return JobOutcome("succeeded", stop_reason=f"evaluation {evaluation_id}", evaluation_id=evaluation_id)
