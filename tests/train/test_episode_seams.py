"""Training reads how an episode ends from the env, and places episodes only through reset options."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium import spaces

from drx.settings.hyperparameters import Hyperparameters
from drx.settings.stop import StopConditions
from drx.sim.episode_status import EpisodeStatus
from drx.train.evaluation import evaluation_episode
from drx.train.records import NullSink
from drx.train.rollout import start_fraction
from drx.train.trainer import Trainer, TrainingSpec

from .conftest import compact_car, real_env_factory


class WheelsOffButGoingOn(gym.Env):
    """Says ``is_offtrack`` for a few steps without ending the episode, then ends it ``off_track``:
    only the env's own ``terminated`` may end an evaluation episode."""

    observation_space = spaces.Box(0, 255, (120, 160, 1), np.uint8)
    action_space = spaces.Discrete(2)

    def __init__(self, end_at: int) -> None:
        self.end_at = end_at
        self.steps = 0

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict]:
        self.steps = 0
        return self.observation_space.sample(), {"params": {"track_length": 10.0}}

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict]:
        self.steps += 1
        done = self.steps >= self.end_at
        status = EpisodeStatus.OFF_TRACK if done else EpisodeStatus.IN_PROGRESS
        info = {"params": {"is_offtrack": True, "progress": float(self.steps)}, "episode_status": status,
                "progress": float(self.steps), "steps": self.steps}  # fmt: skip
        return self.observation_space.sample(), 1.0, done, False, info


class FirstAction:
    """A model whose most probable action is always 0."""

    def predict(self, obs: Any, deterministic: bool = True) -> tuple[int, None]:
        return 0, None


def test_training_evaluation_ends_where_the_env_says() -> None:
    model: Any = FirstAction()
    record = evaluation_episode(model, WheelsOffButGoingOn(end_at=7), compact_car(), 0, 0)
    assert record is not None
    assert record.steps == 7 and record.status == "off_track" and type(record.status) is str


class Records(NullSink):
    def __init__(self) -> None:
        self.episodes: list[Any] = []

    def on_episode(self, record: Any) -> None:
        self.episodes.append(record)


def test_a_resumed_run_continues_the_round_robin(tmp_path: Path) -> None:
    """The second job starts episode 5 where DeepRacer's round robin puts it (25% of the lap), through
    the env's ``episode`` reset option."""
    car = compact_car()
    folder = tmp_path / "model"

    def spec(episodes: int) -> TrainingSpec:
        return TrainingSpec(
            vehicle=car, hyperparameters=Hyperparameters(episodes_per_iteration=5),
            stop=StopConditions(max_minutes=None, max_episodes=episodes), folder=folder,
            env_factory=real_env_factory(Path("oval"), car), eval_episodes=1, seed=0, threads=1,
        )  # fmt: skip

    first, second = Records(), Records()
    Trainer(spec(5), first).run()
    Trainer(spec(5), second).run()
    numbers = [r.global_episode for r in first.episodes + second.episodes]
    assert numbers == list(range(10))
    for r in first.episodes + second.episodes:
        assert r.start_fraction == pytest.approx(start_fraction(r.global_episode), abs=1e-6)
