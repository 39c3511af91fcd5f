"""A real, short training run for the analysis tests, recorded in the registry.

Until the queue's job runner lands, :class:`RegistrySink` (test-only) writes the
trainer's records as the ``episodes``, ``iteration_metrics`` and ``checkpoints`` rows.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import torch

from drx.analysis.data import model_folder
from drx.registry import Checkpoint, Episode, IterationMetric, session_scope
from drx.services import models as model_service
from drx.sim.env import DeepRacerEnv
from drx.train.hyperparameters import Hyperparameters
from drx.train.records import CheckpointRecord, EpisodeRecord, IterationSummary
from drx.train.stop import StopConditions
from drx.train.trainer import Trainer, TrainingSpec

MAX_STEPS = 300  # per episode: keeps a tiny run to a few seconds


class RegistrySink:
    """Writes a run's episodes, iteration metrics and checkpoints for one model."""

    def __init__(self, model_id: int) -> None:
        self.model_id = model_id

    def on_episode(self, record: EpisodeRecord) -> None:
        """Written per iteration."""

    def on_iteration(self, summary: IterationSummary, episodes: list[EpisodeRecord]) -> None:
        """One ``iteration_metrics`` row and its episodes."""
        with session_scope() as session:
            for r in episodes:
                session.add(
                    Episode(
                        model_id=self.model_id,
                        iteration=r.iteration,
                        episode=r.episode,
                        phase=r.phase,
                        reward=r.reward,
                        progress=r.progress,
                        steps=r.steps,
                        status=r.status,
                        lap_time=r.lap_time,
                        start_fraction=r.start_fraction,
                    )
                )
            session.add(
                IterationMetric(
                    model_id=self.model_id,
                    iteration=summary.iteration,
                    steps=summary.steps,
                    episodes=summary.episodes,
                    train_mean_reward=summary.train_mean_reward,
                    train_mean_progress=summary.train_mean_progress,
                    eval_mean_reward=summary.eval_mean_reward,
                    eval_mean_progress=summary.eval_mean_progress,
                    policy_loss=summary.policy_loss,
                    value_loss=summary.value_loss,
                    entropy=summary.entropy,
                    kl=summary.kl,
                    learning_rate=summary.learning_rate,
                    steps_per_second=summary.steps_per_second,
                    elapsed_seconds=summary.elapsed_seconds,
                )
            )

    def on_checkpoint(self, record: CheckpointRecord) -> None:
        """One ``checkpoints`` row; the best one moves."""
        with session_scope() as session:
            if record.is_best:
                for cp in session.query(Checkpoint).filter_by(model_id=self.model_id, is_best=True):
                    cp.is_best = False
            session.add(
                Checkpoint(
                    model_id=self.model_id,
                    iteration=record.iteration,
                    path=record.best_path or record.path,
                    steps=record.steps,
                    episodes=record.episodes,
                    eval_progress=record.eval_progress,
                    eval_lap_time=record.eval_lap_time,
                    is_best=record.is_best,
                )
            )
            model_service.set_status(session, self.model_id, "ready")

    def on_step(self, steps: int) -> None:
        """Ignore."""

    def stop_requested(self) -> bool:
        """Never."""
        return False

    def on_discard(self, iteration: int) -> None:
        """Ignore."""


def train_tiny(
    name: str, episodes: int = 10, per_iteration: int = 5, car: str = "default", **create: Any
) -> Path:
    """Create model ``name`` (compact network) and train it for ``episodes`` episodes; return its folder."""
    torch.set_num_threads(1)
    model = model_service.create_model(
        name,
        car=car,
        network="compact",
        hyperparameters={"episodes_per_iteration": per_iteration, "num_epochs": 3},
        **create,
    )
    vehicle = model.vehicle()
    folder = model_folder(model)
    hp = Hyperparameters.from_dict(model.hyperparameters)
    spec = TrainingSpec(
        vehicle=vehicle,
        hyperparameters=hp,
        stop=StopConditions(max_minutes=None, max_episodes=episodes),
        folder=folder,
        eval_episodes=2,
        seed=1,
        env_factory=lambda mode: DeepRacerEnv(
            track=model.track_name, vehicle=vehicle, mode=mode, max_steps=MAX_STEPS
        ),
    )
    Trainer(spec, RegistrySink(model.id)).run()
    return folder
