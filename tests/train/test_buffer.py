"""Episode buffers grow past their initial room and compute advantages on the filled part only."""

from __future__ import annotations

import numpy as np
import pytest
import torch as th
from gymnasium import spaces

from drx.train.buffer import EpisodeRolloutBuffer, PooledReplayBuffer, pool_frames


def test_grows_and_cuts_at_the_episode_boundary() -> None:
    obs_space = spaces.Box(0, 255, (1, 8, 8), np.uint8)
    buf = EpisodeRolloutBuffer(4, obs_space, spaces.Discrete(3), device="cpu", gamma=0.5, gae_lambda=1.0)
    for t in range(7):  # two episodes: 3 steps then 4 steps
        start = t in (0, 3)
        buf.add(np.zeros((1, 1, 8, 8), np.uint8), np.array([[1]]), np.array([1.0]), np.array([start]),
                th.zeros(1), th.zeros(1))  # fmt: skip
    assert buf.buffer_size == 8 and buf.pos == 7
    assert buf.finish(th.tensor([100.0]), np.array([True])) == 7
    assert buf.buffer_size == 7 and buf.full
    # Returns restart at each episode; the bootstrap value 100 is ignored (terminal).
    assert np.allclose(buf.returns[:3, 0], [1.75, 1.5, 1.0])
    assert np.allclose(buf.returns[3:, 0], [1.875, 1.75, 1.5, 1.0])
    batches = list(buf.get(4))
    assert sum(len(b.returns) for b in batches) == 7


def test_pooled_storage() -> None:
    obs_space = spaces.Box(0, 255, (1, 120, 160), np.uint8)
    buf = EpisodeRolloutBuffer(2, obs_space, spaces.Discrete(3), device="cpu", pool=4)
    frame = np.full((1, 1, 120, 160), 200, np.uint8)
    buf.add(frame, np.array([[0]]), np.array([0.0]), np.array([True]), th.zeros(1), th.zeros(1))
    assert buf.observations.shape[2:] == (1, 30, 40) and np.allclose(buf.observations[0], 200.0)


def test_sac_stores_pooled_frames_and_trains_on_them() -> None:
    """SAC with the compact network keeps frames pooled (PooledReplayBuffer) and its networks read
    them as they read raw frames: the same actions from a pooled frame and from the raw one."""
    from drx.settings.hyperparameters import Hyperparameters
    from drx.train import algorithms

    from .conftest import compact_car
    from .dummy_env import CorridorEnv

    env = CorridorEnv(vehicle=compact_car(continuous=True))
    model = algorithms.build_algorithm(env, "compact", Hyperparameters.default("sac"), seed=0)
    buf = model.replay_buffer
    assert isinstance(buf, PooledReplayBuffer) and buf.observations.shape[2:] == (1, 30, 40)
    frame = np.random.default_rng(0).integers(0, 256, (1, 1, 120, 160), dtype=np.uint8)
    buf.add(frame, frame, np.zeros((1, 2)), np.zeros(1), np.zeros(1), [{}])
    assert buf.observations[0] == pytest.approx(pool_frames(frame.astype(np.float32), 4))
    with th.no_grad():
        pooled = model.actor(th.as_tensor(buf.observations[0]), deterministic=True)
        raw = model.actor(th.as_tensor(frame), deterministic=True)
    assert pooled.numpy() == pytest.approx(raw.numpy(), abs=1e-5)
    model.train(gradient_steps=2, batch_size=1)  # a gradient step on the pooled frames runs
