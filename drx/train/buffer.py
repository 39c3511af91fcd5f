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

from collections.abc import Collection, Iterator
from contextlib import contextmanager
from typing import Any

import numpy as np
import torch as th
from stable_baselines3.common.buffers import DictRolloutBuffer, ReplayBuffer, RolloutBuffer
from stable_baselines3.common.type_aliases import DictRolloutBufferSamples, RolloutBufferSamples

_STEP_ARRAYS = ("actions", "rewards", "returns", "episode_starts", "values", "log_probs", "advantages")


def _resize(array: np.ndarray, size: int) -> np.ndarray:
    """``array`` with its first axis cut or zero-padded to ``size``."""
    if size <= array.shape[0]:
        return array[:size]
    out = np.zeros((size, *array.shape[1:]), dtype=array.dtype)
    out[: array.shape[0]] = array
    return out


class _EpisodeBufferMixin:
    """Growing and cutting, shared by the array and dict buffers; frames scaled once per update."""

    buffer_size: int
    pos: int
    full: bool
    observations: Any
    device: th.device
    # Inside divided_frames(): the observations as tensors (frames divided), handed out by
    # index_select instead of SB3's numpy indexing, copy and the policy's per-minibatch division.
    _divided = False
    _divisor = 1.0
    _divide_keys: frozenset[str] = frozenset()
    _frames: dict[str, th.Tensor] | None = None

    @contextmanager
    def divided_frames(self, by: float, keys: Collection[str]) -> Iterator[None]:
        """Within this context :meth:`get` hands out observations as tensors with the frames of
        ``keys`` divided by ``by``, as SB3's ``preprocess_obs`` would make them (a policy then
        reads them as they are); outside it, as SB3 does. The stored arrays are not changed.

        SB3's policy divides each minibatch's frames by 255 after SB3's buffer gathered them with
        numpy and copied them to torch: ten times per frame in an update of 10 epochs. Here frames
        stored as float32 (pooled ones) are divided once per update, into a copy (4.8 kB a step);
        frames stored as uint8 are gathered as bytes and divided per minibatch (a float copy of an
        iteration's full frames would take 77 kB a step). Either way they are bit-identical to
        SB3's (the same float32 division).

        :param by: the divisor (255 for SB3's image normalisation).
        :param keys: the keys of the observations holding frames, for dict observations (the others
            are handed out in float, as stored); ``""`` for array observations.
        """
        assert self.full, "divided_frames() needs a finished buffer"
        self._divided, self._divisor, self._divide_keys = True, by, frozenset(keys)
        try:
            yield
        finally:
            self._divided, self._frames = False, None

    def _frames_at(self, batch_inds: np.ndarray) -> th.Tensor | dict[str, th.Tensor]:
        """The observations of ``batch_inds``, frames divided (after SB3's get() flattened the arrays)."""
        if self._frames is None:  # once per update: float frames divided, the others as stored
            arrays = self.observations if isinstance(self.observations, dict) else {"": self.observations}
            self._frames = {}
            for key, array in arrays.items():
                tensor = th.as_tensor(array, device=self.device)
                if key in self._divide_keys and tensor.is_floating_point():
                    tensor = tensor / self._divisor
                self._frames[key] = tensor
        index = th.as_tensor(batch_inds, device=self.device)
        out = {}
        for key, tensor in self._frames.items():
            batch = tensor.index_select(0, index)
            if not batch.is_floating_point():
                batch = batch.float()  # as SB3's preprocess_obs hands a Box observation on
                if key in self._divide_keys:
                    batch.div_(self._divisor)
            out[key] = batch
        return out if isinstance(self.observations, dict) else out[""]

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


def _step_data(buffer: Any, batch_inds: np.ndarray) -> tuple[np.ndarray, ...]:
    """A minibatch's actions, values, log-probabilities, advantages and returns, as SB3 takes them."""
    return (
        buffer.actions[batch_inds].astype(np.float32, copy=False),  # SB3 hands actions out as float32
        buffer.values[batch_inds].flatten(),
        buffer.log_probs[batch_inds].flatten(),
        buffer.advantages[batch_inds].flatten(),
        buffer.returns[batch_inds].flatten(),
    )


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

    def _get_samples(self, batch_inds: np.ndarray, env: Any = None) -> RolloutBufferSamples:
        """SB3's minibatch; its frames divided within :meth:`divided_frames`."""
        if not self._divided:
            return super()._get_samples(batch_inds, env)
        frames = self._frames_at(batch_inds)
        assert isinstance(frames, th.Tensor)
        return RolloutBufferSamples(frames, *map(self.to_torch, _step_data(self, batch_inds)))

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

    def _get_samples(self, batch_inds: np.ndarray, env: Any = None) -> DictRolloutBufferSamples:  # type: ignore[override]
        """SB3's minibatch; its frames divided within :meth:`divided_frames`."""
        if not self._divided:
            return super()._get_samples(batch_inds, env)
        frames = self._frames_at(batch_inds)
        assert isinstance(frames, dict)
        return DictRolloutBufferSamples(frames, *map(self.to_torch, _step_data(self, batch_inds)))


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
