"""Rollout buffers that hold a whole number of episodes, however long they run.

SB3's ``RolloutBuffer`` holds a fixed number of steps. A DeepRacer iteration is
a fixed number of *episodes*, whose length is not known in advance, so these
buffers start with room for ``buffer_size`` steps, grow (doubling) when an
iteration runs longer, and at the end of the iteration are cut to the steps
actually filled before advantages are computed. Cutting at the episode
boundary means the last step is always terminal (or bootstrapped by a
truncation value), so nothing leaks between iterations.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch as th
from stable_baselines3.common.buffers import DictRolloutBuffer, ReplayBuffer, RolloutBuffer

_STEP_ARRAYS = ("actions", "rewards", "returns", "episode_starts", "values", "log_probs", "advantages")


def _resize(array: np.ndarray, size: int) -> np.ndarray:
    """``array`` with its first axis cut or zero-padded to ``size``."""
    if size <= array.shape[0]:
        return array[:size]
    out = np.zeros((size, *array.shape[1:]), dtype=array.dtype)
    out[: array.shape[0]] = array
    return out


class _EpisodeBufferMixin:
    """Growing and cutting, shared by the array and dict buffers."""

    buffer_size: int
    pos: int
    full: bool
    observations: Any

    def _resize_all(self, size: int) -> None:
        if isinstance(self.observations, dict):
            self.observations = {k: _resize(v, size) for k, v in self.observations.items()}
        else:
            self.observations = _resize(self.observations, size)
        for name in _STEP_ARRAYS:
            setattr(self, name, _resize(getattr(self, name), size))
        self.buffer_size = size

    def add(self, *args: Any, **kwargs: Any) -> None:
        """Add one step, growing the buffer first when it is full."""
        if self.pos >= self.buffer_size:
            self._resize_all(2 * self.buffer_size)
            self.full = False
        super().add(*args, **kwargs)  # type: ignore[misc]
        self.full = False  # only finish() marks the buffer ready

    def finish(self, last_values: th.Tensor, dones: np.ndarray) -> int:
        """Cut the buffer to the filled steps and compute returns and GAE advantages.

        :param last_values: value of the observation after the last step (ignored where ``dones``).
        :param dones: whether the last step ended its episode, per env.
        :return: the number of steps in the buffer.
        """
        assert self.pos > 0, "finish() needs at least one step in the buffer"
        self._resize_all(self.pos)
        self.full = True
        self.compute_returns_and_advantage(last_values=last_values, dones=dones)  # type: ignore[attr-defined]
        return self.pos

    @property
    def n_steps(self) -> int:
        """Steps added since the last reset."""
        return self.pos


def pool_frames(obs: np.ndarray, factor: int) -> np.ndarray:
    """Average ``factor`` x ``factor`` pixel blocks of channel-first frames ``(..., C, H, W)`` (float32)."""
    *lead, c, h, w = obs.shape
    blocks = obs.reshape(*lead, c, h // factor, factor, w // factor, factor)
    return blocks.mean(axis=(-3, -1), dtype=np.float32)


def pooled_frame_array(size: int, n_envs: int, obs_shape: tuple[int, ...], pool: int) -> np.ndarray:
    """Zeroed float32 room for ``size`` steps of channel-first frames averaged over ``pool`` blocks."""
    c, h, w = obs_shape
    return np.zeros((size, n_envs, c, h // pool, w // pool), dtype=np.float32)


class EpisodeRolloutBuffer(_EpisodeBufferMixin, RolloutBuffer):
    """A :class:`RolloutBuffer` for whole episodes (array observations).

    :param pool: when > 1, frames are stored averaged over ``pool`` x ``pool`` blocks
        (float32, still on the 0-255 scale). A network whose first layer is that same
        average pool (drx's ``compact``) then trains on a sixteenth of the pixels
        without any change to what it computes.
    """

    def __init__(self, buffer_size: int, *args: Any, pool: int = 1, **kwargs: Any) -> None:
        self._initial_size = buffer_size
        self.pool = int(pool)
        super().__init__(buffer_size, *args, **kwargs)

    def reset(self) -> None:
        """Empty the buffer and go back to its initial capacity."""
        self.buffer_size = self._initial_size
        super().reset()
        if self.pool > 1:
            self.observations = pooled_frame_array(self.buffer_size, self.n_envs, self.obs_shape, self.pool)

    def add(self, obs: np.ndarray, *args: Any, **kwargs: Any) -> None:  # type: ignore[override]
        """Add one step (its frame pooled when the buffer pools)."""
        if self.pool > 1:
            obs = pool_frames(np.asarray(obs), self.pool)
        super().add(obs, *args, **kwargs)


class EpisodeDictRolloutBuffer(_EpisodeBufferMixin, DictRolloutBuffer):
    """A :class:`DictRolloutBuffer` for whole episodes (camera + lidar observations).

    :param pool: must be 1: dict observations are stored as they come.
    """

    def __init__(self, buffer_size: int, *args: Any, pool: int = 1, **kwargs: Any) -> None:
        assert pool == 1, "EpisodeDictRolloutBuffer stores frames as they come; use pool=1"
        self._initial_size = buffer_size
        super().__init__(buffer_size, *args, **kwargs)

    def reset(self) -> None:
        """Empty the buffer and go back to its initial capacity."""
        self.buffer_size = self._initial_size
        super().reset()


class PooledReplayBuffer(ReplayBuffer):
    """SB3's :class:`ReplayBuffer` storing frames averaged over ``pool`` x ``pool`` blocks, as
    :class:`EpisodeRolloutBuffer` does for PPO: SAC's gradient step (one per environment step)
    then reads a sixteenth of the pixels through drx's ``compact`` network, which computes the
    same function on them (it skips its own first pooling layer), and the buffer holds the
    same 20,000 transitions in a quarter of the memory.

    :param pool: the block size (1: frames stored as they come).
    Other arguments are SB3's.
    """

    def __init__(self, *args: Any, pool: int = 1, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.pool = int(pool)
        if self.pool > 1:
            self.observations = pooled_frame_array(self.buffer_size, self.n_envs, self.obs_shape, self.pool)
            if not self.optimize_memory_usage:
                self.next_observations = np.zeros_like(self.observations)

    def add(self, obs: np.ndarray, next_obs: np.ndarray, *args: Any, **kwargs: Any) -> None:  # type: ignore[override]
        """Add one transition (its frames pooled when the buffer pools)."""
        if self.pool > 1:
            obs = pool_frames(np.asarray(obs), self.pool)
            next_obs = pool_frames(np.asarray(next_obs), self.pool)
        super().add(obs, next_obs, *args, **kwargs)
