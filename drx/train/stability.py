"""What drx's PPO (and SAC's reward scale) do differently from DeepRacer's to train stably.

DeepRacer's console runs a few dozen PPO updates an hour; drx runs that many a minute, so
instabilities a DeepRacer user rarely meets are what every drx user would meet. Three named
choices, each measured on the race-pace experiments (``benchmarks/race_pace.py``,
``docs/RACING.md``). None changes what a DeepRacer hyperparameter means.

**Value targets in units of the return's spread** (:class:`ReturnScale`). A reward such as the
"pursuit" reward (``progress / steps * 100 + speed**2``) pays 50-120 a step, so discounted
returns run into the thousands. drx's value head shares the network with the policy by default
(``towers`` ``shared``; DeepRacer's heads do not: its value tower ``network_0`` and policy tower
``network_1`` share no weight, as the real checkpoints in ``../shared/deepracer-models/`` show),
and a value loss on targets in the thousands gives every trunk weight a gradient of the same
sign on every minibatch (Huber's slope is +-1 out there), which Adam turns into full-size steps:
the features the policy reads drift on every update. (With separate towers the value loss moves
only the value tower; the scale still keeps its targets near 1.) Measured on A to Z Speedway
with continuous actions (one trunk), each update's approximate KL was 0.05-0.15 from the first
iteration (PPO runs near 0.01), the clip fraction 0.3-0.5, and the run collapsed within a
minute; with the rewards divided by the running root-mean-square of the discounted return before
GAE, the KL is 0.006-0.01, the clip fraction 0.07-0.13, the value head explains 70-80% of the
return's variance and the run laps in 40 s and keeps lapping. Advantages are normalised per
minibatch anyway (SB3, DeepRacer), so the policy's update sees the same signal; only the value
head's scale changes. This is the reward scaling of Stable-Baselines3's
``VecNormalize(norm_reward=True)`` and CleanRL's ``ppo_continuous_action.py`` (gymnasium's
``NormalizeReward``); drx uses the root-mean-square rather than the standard deviation, so a
reward that pays about the same every step still gets targets near 1, and an exponential average
over iterations, so the scale follows a car that gets faster.

**The Gaussian's spread is capped at DeepRacer's starting spread** (:data:`MAX_LOG_STD`).
DeepRacer's continuous head (deepracer-simapp ``rl_coach/.../heads/ppo_head.py``) starts its
state-independent log-std at 0, a standard deviation of 1 in the normalised action box
[-1, 1] (``ScalableBoxActionSpace``). The console's continuous training traces
(``../shared/deepracer-logs/console-continuous-2021/``) show it: in the first iteration 32%
of the sampled steering and 34% of the speeds sit on a bound, the share of a unit Gaussian
clipped to [-1, 1] (31.7%), and the spread of the samples is 0.72 of the half-range, a
clipped unit Gaussian's. Wider than that, most samples land on a bound, where every sample
drives the same and the mean stops mattering: the issue's runs grew the spread tenfold
(entropy 2.85 -> 7.6) before they collapsed. The log-std is clamped to ``<= 0`` after every
optimizer step.

**The action mean is kept inside the box** (:func:`bound_loss`). The environment clips an
action to the box, so a mean past a bound drives exactly as the bound does and the samples
beyond it tell the update nothing: the mean wanders out there and the most probable action,
which evaluation and the physical car drive, is stuck on a bound (the issue's collapsed
policy steered +26 deg in every section). A squared penalty on the part of the mean past
+-1 (rl_games' ``bounds_loss``, used by NVIDIA's Isaac Gym PPO) pulls it back; inside the box
it is zero and changes nothing.

**SAC's rewards in units of their size a step** (:class:`RewardScale`): the same running
root-mean-square, of the reward of one step rather than the return, for the reason given in
:mod:`drx.train.sac` (its temperature weighs entropy against one step's reward).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch as th
from torch.nn import functional as F

MAX_LOG_STD = 0.0  # DeepRacer's initial log-std: a spread of 1 in the normalised action box
BOUND_LOSS_COEF = 1.0  # weight of the squared part of the action mean past +-1
RMS_MOMENTUM = 0.9  # share of the previous iterations' RMS (of returns, or rewards) kept at each update
_MIN_RMS = 1e-6


def bound_loss(mean: th.Tensor) -> th.Tensor:
    """The mean over a batch of the squared amounts by which each action mean lies past +-1.

    :param mean: ``(batch, action_dim)`` Gaussian means in the normalised action box.
    """
    return (F.relu(mean.abs() - 1.0) ** 2).sum(dim=1).mean()


def cap_log_std(log_std: th.Tensor) -> None:
    """Clamp a policy's log-std parameter in place to ``<= MAX_LOG_STD`` (no gradient)."""
    with th.no_grad():
        log_std.clamp_(max=MAX_LOG_STD)


def discounted_returns(rewards: np.ndarray, episode_starts: np.ndarray, gamma: float) -> np.ndarray:
    """Each step's discounted return to the end of its episode (every episode in the buffer ended).

    :param rewards: ``(n,)`` rewards in step order, whole episodes one after another.
    :param episode_starts: ``(n,)`` True on each episode's first step.
    :param gamma: discount factor.
    """
    out = np.zeros(len(rewards), dtype=np.float64)
    running = 0.0
    for i in range(len(rewards) - 1, -1, -1):
        running = float(rewards[i]) + gamma * running
        out[i] = running
        if episode_starts[i]:
            running = 0.0
    return out


@dataclass
class RunningRMS:
    """An exponential running root-mean-square over iterations, kept in checkpoints.

    :param rms: the current value (``None`` until the first update).
    :param momentum: share of the old square kept when an iteration's values come in.
    """

    rms: float | None = None
    momentum: float = RMS_MOMENTUM

    def update(self, values: np.ndarray) -> float:
        """Fold one iteration's values in; return the scale to divide by."""
        if values.size:
            square = float(np.mean(np.square(values)))
            old = self.rms**2 if self.rms is not None else square
            self.rms = math.sqrt(self.momentum * old + (1.0 - self.momentum) * square)
        return self.value

    @property
    def value(self) -> float:
        """The scale to divide by now (1 before any update)."""
        return max(self.rms or 1.0, _MIN_RMS)

    def state(self) -> dict[str, Any]:
        """JSON-friendly state, kept in the checkpoint so a resumed or cloned run goes on with it."""
        return {"rms": self.rms}

    def restore(self, state: dict[str, Any] | None) -> None:
        """Take a :meth:`state` back (an older checkpoint without one leaves the scale unset)."""
        rms = (state or {}).get("rms")
        self.rms = float(rms) if rms is not None and math.isfinite(float(rms)) and rms > 0 else None


class ReturnScale(RunningRMS):
    """The running root-mean-square of the discounted return, which PPO divides rewards by before
    GAE (see the module docstring)."""

    def scale_rewards(self, rewards: np.ndarray, episode_starts: np.ndarray, gamma: float) -> np.ndarray:
        """Update the scale with these whole episodes' returns and return the rewards divided by it."""
        scale = self.update(discounted_returns(rewards, episode_starts, gamma))
        return rewards / scale


class RewardScale(RunningRMS):
    """The running root-mean-square of the reward of one step, which SAC divides rewards by, so
    that its temperature ``sac_alpha`` weighs entropy against a reward of about 1 a step
    whatever the reward function pays (:mod:`drx.train.sac`)."""
