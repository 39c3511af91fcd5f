"""The job kinds: one table saying, for each kind, which function runs it and what its states mean.

Every job of the ``jobs`` table has one of these kinds. The lifecycle
(:mod:`drx.queue.lifecycle`) reads ``trains_model`` and ``max_attempts`` here;
``drx job run ID`` (:func:`drx.queue.dispatch.run_job`) looks the job's runner up
here by the kind's name, as procrastinate's worker looks a task up in its registry.
Runners are named ``"module:function"`` and imported only by the process that runs
the job, so that listing or claiming jobs never loads torch.
"""

from __future__ import annotations

from dataclasses import dataclass

from drx.errors import DrxError


@dataclass(frozen=True)
class JobKind:
    """One kind of job.

    :param name: the kind, as stored in ``jobs.kind``.
    :param runner: ``"module:function"``; the function takes a :class:`drx.queue.dispatch.JobRun`
        and returns a :class:`drx.queue.dispatch.JobOutcome`.
    :param trains_model: the job's state changes move its model's status (``queued``, ``training``,
        ``ready``...) and drop the model's rows past its last checkpoint; an evaluation leaves both alone.
    :param max_attempts: how often a job is started before a lost worker fails it instead of requeuing it.
    """

    name: str
    runner: str
    trains_model: bool
    max_attempts: int = 3


KINDS: dict[str, JobKind] = {
    kind.name: kind
    for kind in (
        JobKind("train", "drx.queue.train_job:run_training", trains_model=True),
        # An evaluation starts over when its worker is lost (nothing is stored until it ends).
        JobKind("evaluate", "drx.queue.evaluate_job:run_evaluation", trains_model=False),
    )
}


def job_kind(name: str) -> JobKind:
    """The kind called ``name``.

    :raises DrxError: no such kind (a row written by another drx version).
    """
    try:
        return KINDS[name]
    except KeyError:
        raise DrxError(
            f"Job kind {name!r} is unknown; this drx runs {', '.join(map(repr, KINDS))} jobs "
            "(upgrade drx on this host)."
        ) from None


def trains_model(name: str) -> bool:
    """Whether jobs of kind ``name`` move their model's status (False for an unknown kind)."""
    kind = KINDS.get(name)
    return kind is not None and kind.trains_model
