"""The job runner's hook for a sweep trial: report each iteration to Optuna and stop when it prunes.

A trial's job carries ``options["sweep"] = {"study": NAME, "trial": N}``. Its sink reports the
sweep's metric once an iteration's checkpoint is written (so a killed worker's lost iteration was
never reported; the resumed job reports it again, overwriting), then asks the study's pruner
(``pruner.prune``, what ``Trial.should_prune`` runs); on "prune" the run stops before its next
iteration and the trial ends ``PRUNED``. A run that ends on its stop conditions completes the trial
with its best iteration's figure. Runs ended by hand, by failure or by a lost lease leave the trial
running: :func:`drx.sweep.service.reconcile` settles it from the job's final status.
Optuna is imported only for jobs that are trials.
"""

from __future__ import annotations

import contextlib
import math
from dataclasses import replace
from typing import TYPE_CHECKING

from drx.registry import Job
from drx.train.records import CheckpointRecord, EpisodeRecord, IterationSummary, TrainingSink
from drx.train.stop import MAX_EPISODES, MAX_MINUTES, MAX_STEPS, TARGET

if TYPE_CHECKING:
    from drx.train.trainer import Trainer, TrainingResult

PRUNED = "pruned"  # the job's stop reason
NATURAL_STOPS = (MAX_MINUTES, MAX_STEPS, MAX_EPISODES, TARGET)


class SweepTrial:
    """One trial of a sweep, as its training job sees it.

    :param study_name: the sweep.
    :param number: the trial's number in the study.
    """

    def __init__(self, study_name: str, number: int) -> None:
        from drx.sweep.optuna_storage import open_storage
        from drx.sweep.service import load_sweep

        self.storage = open_storage()
        self.spec, self.study = load_sweep(study_name, self.storage)
        self.number = number
        study_id = self.storage.get_study_id_from_name(study_name)
        self.trial_id = self.storage.get_trial_id_from_study_id_trial_number(study_id, number)
        self.pruned = False

    @classmethod
    def of(cls, job: Job) -> SweepTrial | None:
        """The trial a job trains, ``None`` for an ordinary job."""
        ref = (job.options or {}).get("sweep")
        return cls(str(ref["study"]), int(ref["trial"])) if ref else None

    def sink(self, inner: TrainingSink) -> TrainingSink:
        """``inner``, also reporting to the study."""
        return PruningSink(inner, self)

    def report(self, iteration: int, value: float) -> bool:
        """Record the iteration's figure; return whether the pruner stops the trial here."""
        self.storage.set_trial_intermediate_value(self.trial_id, iteration, value)
        if self.pruned:
            return True
        self.pruned = bool(self.study.pruner.prune(self.study, self.storage.get_trial(self.trial_id)))
        return self.pruned

    def run(self, trainer: Trainer) -> TrainingResult:
        """Train (unless the trial already ended), then tell the study how the trial ended."""
        import optuna

        from drx.sweep.metric import best_value
        from drx.train.trainer import TrainingResult

        state = self.storage.get_trial(self.trial_id).state
        if state.is_finished():  # told, then the worker died before it ended the job
            st = trainer.state
            return TrainingResult(
                stop_reason=PRUNED if state == optuna.trial.TrialState.PRUNED else "done",
                iterations=0,
                steps=st.steps,
                episodes=st.episodes,
                best=st.best,
                last_iteration=st.iteration,
            )
        result = trainer.run()
        values = list(self.storage.get_trial(self.trial_id).intermediate_values.values())
        with contextlib.suppress(RuntimeError):  # told meanwhile by `drx sweep show` (job looked ended)
            if self.pruned:
                self.study.tell(self.number, state=optuna.trial.TrialState.PRUNED)
                return replace(result, stop_reason=PRUNED)
            if result.stop_reason in NATURAL_STOPS and values:
                self.study.tell(self.number, best_value(self.spec.metric, values))
        return result


class PruningSink:
    """Forwards to ``inner``; reports each durable iteration to the trial and stops when pruned."""

    def __init__(self, inner: TrainingSink, trial: SweepTrial) -> None:
        self.inner = inner
        self.trial = trial
        self._values: dict[int, float] = {}

    def on_episode(self, record: EpisodeRecord) -> None:
        """Forward."""
        self.inner.on_episode(record)

    def on_iteration(self, summary: IterationSummary, episodes: list[EpisodeRecord]) -> None:
        """Forward, and keep the iteration's figure until its checkpoint."""
        from drx.sweep.metric import iteration_value

        self.inner.on_iteration(summary, episodes)
        value = iteration_value(self.trial.spec.metric, summary)
        if value is not None and not math.isnan(value):
            self._values[summary.iteration] = value

    def on_checkpoint(self, record: CheckpointRecord) -> None:
        """Forward; the iteration is durable now, so report it and ask the pruner."""
        self.inner.on_checkpoint(record)
        value = self._values.pop(record.iteration, None)
        if value is not None:
            self.trial.report(record.iteration, value)

    def on_step(self, steps: int) -> None:
        """Forward."""
        self.inner.on_step(steps)

    def stop_requested(self) -> bool:
        """Stop when asked, or when pruned."""
        return self.trial.pruned or self.inner.stop_requested()

    def on_discard(self, iteration: int) -> None:
        """Forward."""
        self._values.pop(iteration, None)
        self.inner.on_discard(iteration)

    def on_phase(self, phase: str, elapsed: float) -> None:
        """Forward (to an inner sink that shows phases)."""
        hook = getattr(self.inner, "on_phase", None)
        if hook is not None:
            hook(phase, elapsed)
