"""Fixtures for trainer tests: small specs over the dummy corridor env and the real simulator."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import gymnasium as gym
import pytest

from drx.settings.hyperparameters import Hyperparameters
from drx.settings.stop import StopConditions
from drx.train.trainer import TrainingSpec
from drx.vehicle import Vehicle, default_vehicle

from .dummy_env import CorridorEnv

SpecFactory = Callable[..., TrainingSpec]


def compact_car(continuous: bool = False, lidar: bool = False) -> Vehicle:
    """DeepRacer's default action space (or a continuous car) with the compact network."""
    if continuous:
        return Vehicle(name="c", continuous=True, speed_range=(0.5, 1.0), network="compact", lidar=lidar)
    return Vehicle(name="c", actions=default_vehicle().actions, network="compact", lidar=lidar)


@pytest.fixture
def corridor_spec(tmp_path: Path) -> SpecFactory:
    """Build a :class:`TrainingSpec` over :class:`CorridorEnv` (a few ms per episode)."""

    def make(
        folder: Path | None = None,
        stop: StopConditions | None = None,
        car: Vehicle | None = None,
        **hp: object,
    ) -> TrainingSpec:
        car = car or compact_car()
        hp.setdefault("episodes_per_iteration", 5)
        return TrainingSpec(
            vehicle=car,
            hyperparameters=Hyperparameters.default(str(hp.pop("algorithm", "ppo"))).replace(**hp),
            stop=stop or StopConditions(max_minutes=None, max_episodes=10),
            folder=folder or tmp_path / "model",
            env_factory=lambda mode: CorridorEnv(car, mode, lidar=car.lidar),
            eval_episodes=2,
            seed=1,
            threads=1,
        )

    return make


def real_env_factory(track: Path, car: Vehicle, reward: object = None) -> Callable[[str], gym.Env]:
    """An env factory for the real simulator on ``track``."""
    import drx.sim.registration as registration

    registration.register_envs()

    def make(mode: str) -> gym.Env:
        return gym.make(registration.ENV_ID, track=str(track), vehicle=car, reward_function=reward, mode=mode)

    return make
