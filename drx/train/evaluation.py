"""Evaluation episodes during training, and a policy's outputs for tests and tools.

After every iteration the trainer drives a few episodes from the start line
with the most probable action, as the DeepRacer console does. An episode ends
when the environment ends it (its ``episode_status``: lap complete, off track,
crashed...; the first step off the track ends it, so the target stop condition
counts laps completed without leaving it); a policy that circles forever is cut
after one and a half laps' worth of steps at the car's slowest speed.

A seeded run seeds every evaluation episode's reset from the run's seed, the iteration and the
episode's index (:func:`evaluation_seed`, a stream apart from the training episodes'), so two runs
with the same seed on the same machine drive the same evaluations and keep the same best checkpoint.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np
import torch as th
from stable_baselines3.common.base_class import BaseAlgorithm

from drx.train.records import EVALUATION, EpisodeRecord
from drx.train.trace import STEP_SECONDS, EpisodeTracker
from drx.vehicle import Vehicle

EVALUATION_STREAM = 0x65_76_61_6C  # "eval": evaluation seeds are not any training episode's


def evaluation_seed(seed: int, iteration: int, index: int) -> int:
    """The env seed of evaluation episode ``index`` after iteration ``iteration`` of a run seeded
    ``seed`` (its simulator's step-time jitter and any other noise of the episode)."""
    sequence = np.random.SeedSequence([int(seed), EVALUATION_STREAM, int(iteration), int(index)])
    return int(sequence.generate_state(1)[0])


def step_cap(vehicle: Vehicle, info: dict[str, Any]) -> int:
    """At most one and a half laps' worth of steps at the car's slowest speed."""
    length = float(info.get("params", {}).get("track_length", 0.0) or 0.0)
    slowest = float(vehicle.speed_range[0]) if vehicle.continuous else min(a.speed for a in vehicle.actions)
    if length <= 0:
        return 5000
    return max(500, int(1.5 * length / max(slowest, 0.1) / STEP_SECONDS))


def evaluation_episode(
    model: BaseAlgorithm,
    env: gym.Env,
    vehicle: Vehicle,
    iteration: int,
    index: int,
    keep_going: Callable[[], bool] | None = None,
    seed: int | None = None,
) -> EpisodeRecord | None:
    """One episode from the start line with the most probable action (``None`` when ``keep_going``
    said stop before it ended); ``seed`` seeds its reset (:func:`evaluation_seed`)."""
    tracker = EpisodeTracker(EVALUATION)
    obs, info = env.reset(seed=seed)
    for _ in range(step_cap(vehicle, info)):
        if keep_going is not None and not keep_going():
            return None
        action, _ = model.predict(obs, deterministic=True)
        obs, reward, terminated, truncated, info = env.step(action)
        tracker.step(float(reward), info)
        if terminated or truncated:  # the env decides how an episode ends (``info["episode_status"]``)
            break
    return tracker.finish(info, iteration, index, index)


def evaluate(
    model: BaseAlgorithm,
    env: gym.Env,
    vehicle: Vehicle,
    iteration: int,
    episodes: int,
    keep_going: Callable[[], bool] | None = None,
    seed: int | None = None,
) -> list[EpisodeRecord]:
    """``episodes`` evaluation episodes of ``model`` in an evaluation-mode ``env``.

    :param keep_going: asked before every step; when it returns False the episode in progress
        is dropped and the finished ones are returned.
    :param seed: the run's seed: each episode's reset is seeded from it (:func:`evaluation_seed`);
        ``None``: unseeded.
    """
    records = []
    for k in range(episodes):
        episode_seed = None if seed is None else evaluation_seed(seed, iteration, k)
        record = evaluation_episode(model, env, vehicle, iteration, k, keep_going, episode_seed)
        if record is None:
            break
        records.append(record)
    return records


def policy_outputs(model: Any, observations: np.ndarray) -> np.ndarray:
    """Action probabilities (discrete) or action means (continuous) for a batch of raw observations."""
    policy = model.policy
    obs_tensor, _ = policy.obs_to_tensor(observations)
    if not hasattr(policy, "get_distribution"):  # SAC: the deterministic (squashed mean) action
        with th.no_grad():
            return policy._predict(obs_tensor, deterministic=True).cpu().numpy()
    with th.no_grad():
        dist = policy.get_distribution(obs_tensor)
        inner = dist.distribution
        if hasattr(inner, "probs"):
            return inner.probs.cpu().numpy()
        return inner.mean.cpu().numpy()
