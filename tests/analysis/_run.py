"""A real, short training run for the analysis tests, through drx's own queue and trainer.

The model is created with the compact network and trained as ``drx train`` does
(a queued job run by :func:`drx.queue.dispatch.run_job`, whose registry sink writes
the ``episodes``, ``iteration_metrics`` and ``checkpoints`` rows and whose trainer
writes the DeepRacer trace).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from drx.analysis.data import model_folder
from drx.queue.dispatch import run_job
from drx.queue.lifecycle import enqueue_training
from drx.services import models as model_service


def train_tiny(name: str, episodes: int = 10, per_iteration: int = 5, **create: Any) -> Path:
    """Create model ``name`` and train it for ``episodes`` episodes; return its folder."""
    model_service.create_model(
        name,
        network="compact",
        hyperparameters={"episodes_per_iteration": per_iteration, "num_epochs": 3},
        stop_conditions={"max_episodes": episodes},
        **create,
    )
    job = enqueue_training(name, {"seed": 1, "eval_episodes": 2, "threads": 1})
    outcome = run_job(job.id)
    assert outcome.status == "succeeded", outcome
    return model_folder(name)
