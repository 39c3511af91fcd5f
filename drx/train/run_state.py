"""Where a training run stands: the counters a checkpoint carries from one attempt to the next."""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any


@dataclass
class RunState:
    """A run's counters (the model's totals across attempts, and this job's own).

    :param iteration: the last completed iteration (-1: none yet).
    :param steps: training steps of the model so far.
    :param episodes: training episodes of the model so far.
    :param elapsed: training seconds of the model so far.
    :param sim_time: simulated seconds of training so far (the trace's clock).
    :param job_steps: training steps of this job (its stop conditions count these).
    :param job_episodes: training episodes of this job.
    :param job_elapsed: training seconds of this job.
    :param streak: iterations in a row whose evaluation laps all reached 100%.
    :param lr_factor: the ``anneal`` schedule's factor on the learning rate
        (:class:`drx.train.anneal.AnnealState`; 1 for a new model, a clone, and other schedules).
    :param anneal_strikes: evaluated iterations in a row, up to the last, slower than the best allows.
    :param rollbacks: how many times ``anneal`` went back to the best checkpoint.
    :param best: the best checkpoint's metadata (``None`` when no iteration completed).
    """

    iteration: int = -1
    steps: int = 0
    episodes: int = 0
    elapsed: float = 0.0
    sim_time: float = 0.0
    job_steps: int = 0
    job_episodes: int = 0
    job_elapsed: float = 0.0
    streak: int = 0
    lr_factor: float = 1.0
    anneal_strikes: int = 0
    rollbacks: int = 0
    best: dict[str, Any] | None = None

    @classmethod
    def resumed(cls, meta: dict[str, Any], best: dict[str, Any] | None, same_job: bool) -> RunState:
        """The state a ``last`` checkpoint's metadata records.

        :param meta: the ``last`` checkpoint's metadata.
        :param best: the ``best`` checkpoint's metadata, if there is one.
        :param same_job: the checkpoint was written by this job (an earlier attempt of it): its
            ``job_*`` counters continue; else they start at 0 and so does the streak. The
            ``anneal`` state is the model's and continues either way (the weights it annealed go on).
        """
        state = cls(best=best)
        for f in fields(cls):
            if f.name in meta and f.name != "best" and (same_job or not f.name.startswith("job_")):
                setattr(state, f.name, meta[f.name])
        if not same_job:
            state.streak = 0
        return state
