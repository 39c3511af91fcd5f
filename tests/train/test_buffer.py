"""Episode buffers grow past their initial room and compute advantages on the filled part only."""

from __future__ import annotations

import numpy as np
import torch as th
from gymnasium import spaces

from drx.train.buffer import EpisodeRolloutBuffer


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
