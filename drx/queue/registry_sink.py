"""The trainer's records, written to the registry.

Episode rows are written as episodes end (so ``drx jobs logs -f`` sees them
live); an iteration cut before its checkpoint has its rows deleted
(``on_discard``), and a resumed attempt first deletes every row past the last
checkpoint (:func:`truncate_after`), so no episode is counted twice or lost.
"""

from __future__ import annotations

from sqlalchemy import delete, update

from drx.queue.heart import Heart
from drx.registry import Checkpoint, Episode, IterationMetric, session_scope
from drx.train.anneal import FIGURES as ANNEAL_FIGURES
from drx.train.records import CheckpointRecord, EpisodeRecord, IterationSummary


def truncate_after(model_id: int, iteration: int) -> None:
    """Delete the model's episode, metric and checkpoint rows of iterations after ``iteration``."""
    with session_scope() as session:
        for table in (Episode, IterationMetric, Checkpoint):
            session.execute(
                delete(table)
                .where(table.model_id == model_id, table.iteration > iteration)
                .execution_options(synchronize_session=False)
            )


class RegistrySink:
    """Writes episodes, iteration metrics and checkpoints of one job to the registry.

    :param model_id: the model trained.
    :param job_id: the job writing (``None`` outside the queue).
    :param heart: the job's :class:`Heart` (its stop flag), when it runs under the queue.
    """

    def __init__(self, model_id: int, job_id: int | None, heart: Heart | None = None) -> None:
        self.model_id = model_id
        self.job_id = job_id
        self.heart = heart

    def on_episode(self, record: EpisodeRecord) -> None:
        """Insert the episode's row (replacing a stale one with the same key)."""
        with session_scope() as session:
            key = (
                Episode.model_id == self.model_id,
                Episode.phase == record.phase,
                Episode.iteration == record.iteration,
                Episode.episode == record.episode,
            )
            session.execute(delete(Episode).where(*key).execution_options(synchronize_session=False))
            session.add(self._episode_row(record))

    def _episode_row(self, r: EpisodeRecord) -> Episode:
        return Episode(
            model_id=self.model_id,
            job_id=self.job_id,
            iteration=r.iteration,
            episode=r.episode,
            phase=r.phase,
            reward=float(r.reward),
            progress=float(r.progress),
            steps=int(r.steps),
            status=r.status[:16],
            lap_time=r.lap_time,
            start_fraction=float(r.start_fraction),
            track_name=r.track,
        )

    def on_iteration(self, summary: IterationSummary, episodes: list[EpisodeRecord]) -> None:
        """Write the iteration's evaluation episodes and its metrics row."""
        with session_scope() as session:
            for r in episodes:
                if r.phase == "evaluation":
                    session.add(self._episode_row(r))
            session.execute(
                delete(IterationMetric)
                .where(
                    IterationMetric.model_id == self.model_id, IterationMetric.iteration == summary.iteration
                )
                .execution_options(synchronize_session=False)
            )
            session.add(
                IterationMetric(
                    model_id=self.model_id,
                    job_id=self.job_id,
                    iteration=summary.iteration,
                    policy_loss=summary.policy_loss,
                    value_loss=summary.value_loss,
                    entropy=summary.entropy,
                    kl=summary.kl,
                    learning_rate=summary.learning_rate,
                    steps=summary.steps,
                    episodes=summary.episodes,
                    steps_per_second=summary.steps_per_second,
                    elapsed_seconds=summary.elapsed_seconds,
                    train_mean_reward=summary.train_mean_reward,
                    train_mean_progress=summary.train_mean_progress,
                    eval_mean_reward=summary.eval_mean_reward,
                    eval_mean_progress=summary.eval_mean_progress,
                    # with the anneal schedule's figures: a rollback is the run's health too
                    health={**summary.health, **_anneal_figures(summary)} or None,
                )
            )

    def on_checkpoint(self, record: CheckpointRecord) -> None:
        """Record the checkpoint; the best one's row points at ``best.zip`` and is the only ``is_best``."""
        with session_scope() as session:
            if record.is_best:
                session.execute(
                    update(Checkpoint)
                    .where(Checkpoint.model_id == self.model_id)
                    .values(is_best=False)
                    .execution_options(synchronize_session=False)
                )
            session.add(
                Checkpoint(
                    model_id=self.model_id,
                    job_id=self.job_id,
                    iteration=record.iteration,
                    path=record.best_path if record.is_best and record.best_path else record.path,
                    steps=record.steps,
                    episodes=record.episodes,
                    eval_progress=record.eval_progress,
                    eval_lap_time=record.eval_lap_time,
                    is_best=record.is_best,
                )
            )

    def on_step(self, steps: int) -> None:
        """Nothing: heartbeats run on their own thread."""

    def stop_requested(self) -> bool:
        """Whether the job was asked to stop (or lost its lease)."""
        return self.heart is not None and (self.heart.stop or self.heart.lost)

    def on_discard(self, iteration: int) -> None:
        """Forget the rows of an iteration that did not reach its checkpoint."""
        truncate_after(self.model_id, iteration - 1)

    def on_phase(self, phase: str, elapsed: float) -> None:
        """Nothing: the registry keeps no phases (``drx jobs logs`` reads iterations and episodes)."""


def _anneal_figures(summary: IterationSummary) -> dict[str, float]:
    """What the summary's ``extra`` records of the ``anneal`` schedule (:data:`drx.train.anneal.FIGURES`)."""
    return {k: summary.extra[k] for k in ANNEAL_FIGURES if k in summary.extra}
