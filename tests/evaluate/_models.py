"""Models with a checkpoint for the evaluation tests: untrained weights, saved as training saves them."""

from __future__ import annotations

from typing import Any

import torch

from drx.atomic import copy_atomic
from drx.registry import Checkpoint, session_scope
from drx.services import models as model_service
from drx.settings.hyperparameters import Hyperparameters
from drx.sim.env import DeepRacerEnv
from drx.sim.track import load_track
from drx.train.algorithms import build_algorithm
from drx.train.checkpoint import checkpoint_path, model_folder, save_checkpoint


def model_with_checkpoint(
    name: str, car: str = "default", iterations: tuple[int, int] = (2, 3), **create: Any
) -> None:
    """Create model ``name`` (compact network; ``create``: more of ``create_model``'s arguments) with
    ``best.zip`` (iteration 2) and ``last.zip`` (3)."""
    torch.set_num_threads(1)
    model = model_service.create_model(name, car=car, network="compact", **create)
    vehicle = model.vehicle()
    env = DeepRacerEnv(track=load_track(model.track_name), vehicle=vehicle, mode="training", max_steps=50)
    hp = Hyperparameters.from_dict(model.hyperparameters, algorithm=model.algorithm)
    algo = build_algorithm(env, vehicle.network, hp, seed=0)
    folder = model_folder(name)
    best_it, last_it = iterations
    last = save_checkpoint(algo, checkpoint_path(folder, "last"), {"iteration": last_it})
    save_checkpoint(algo, checkpoint_path(folder, "best"), {"iteration": best_it})
    copy_atomic(last, checkpoint_path(folder, "last"))
    with session_scope() as session:
        for it, which, best in ((best_it, "best", True), (last_it, "last", False)):
            session.add(
                Checkpoint(
                    model_id=model.id, iteration=it, path=str(checkpoint_path(folder, which)), is_best=best
                )
            )
