"""A short training run in each race type, with the stereo camera + lidar car (Dict observations)."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import pytest

from drx.settings.hyperparameters import Hyperparameters
from drx.settings.stop import StopConditions
from drx.train.trainer import Trainer, TrainingSpec
from drx.vehicle import Vehicle, default_vehicle

from ._tracks import shared_path

ROOT = Path(__file__).resolve().parents[2]
RACES = {
    "time-trial": (None, "follow_center_line.py"),
    "object-avoidance": ({"race_type": "object-avoidance", "objects": 3, "randomize_objects": True},
                         "object_avoidance.py"),
    "head-to-bot": ({"race_type": "head-to-bot", "bots": 2, "bot_speed": 0.5, "bot_lane_change": True},
                    "head_to_bot.py"),
}  # fmt: skip


@pytest.mark.parametrize("race_type", sorted(RACES))
def test_a_short_training_run_in_each_race_type(race_type: str, tmp_path: Path) -> None:
    import drx.sim.registration as registration

    registration.register_envs()
    race, reward = RACES[race_type]
    car = Vehicle(
        name="sl", actions=default_vehicle().actions, sensor="stereo", lidar=True, network="compact"
    )
    track = shared_path("reinvent_base")
    statuses: list[str] = []

    def make(mode: str) -> gym.Env:
        env = gym.make(registration.ENV_ID, track=str(track), vehicle=car, mode=mode, race=race,
                       reward_function=str(ROOT / "rewards" / reward), max_steps=150)  # fmt: skip
        return _Statuses(env, statuses)

    spec = TrainingSpec(
        vehicle=car,
        hyperparameters=Hyperparameters.default("ppo").replace(episodes_per_iteration=5, batch_size=32),
        stop=StopConditions(max_minutes=None, max_episodes=5),
        folder=tmp_path / "model",
        env_factory=make,
        eval_episodes=1,
        seed=1,
        threads=1,
    )
    result = Trainer(spec).run()
    assert result.iterations == 1 and result.episodes == 5 and result.best is not None
    assert (tmp_path / "model").is_dir() and any((tmp_path / "model").rglob("*.zip"))
    assert statuses and set(statuses) <= {"off_track", "crashed", "lap_complete", "immobilized", "reversed",
                                          "time_up"}  # fmt: skip


class _Statuses(gym.Wrapper):
    """Records how each episode ended."""

    def __init__(self, env: gym.Env, out: list[str]) -> None:
        super().__init__(env)
        self._out = out

    def step(self, action: object) -> tuple:
        obs, reward, terminated, truncated, info = self.env.step(action)
        if terminated or truncated:
            self._out.append(info["episode_status"])
        return obs, reward, terminated, truncated, info
