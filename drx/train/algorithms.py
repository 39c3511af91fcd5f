"""Building the SB3 algorithm for a car, a network and DeepRacer hyperparameters."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
from gymnasium import spaces
from stable_baselines3.common.base_class import BaseAlgorithm
from stable_baselines3.common.logger import Logger

from drx.errors import DrxError
from drx.settings.hyperparameters import Hyperparameters
from drx.train.buffer import PooledReplayBuffer
from drx.train.networks import input_pool, policy_kwargs_for
from drx.train.ppo import BatchHook, EpisodicPPO
from drx.train.sac import EpisodicSAC
from drx.train.vecenv import SingleVecEnv

INITIAL_BUFFER_STEPS = 2048  # PPO buffer's starting room [steps]; it grows for long iterations
# What an update records beyond its losses, entropy and KL, to tell a healthy run from a dying
# one (drx.train.stability); the trainer keeps them in the iteration's ``health`` figures. PPO
# records all but the reward scale; SAC the spread, the shares on a bound and its reward scale.
HEALTH_FIGURES = (
    "clip_fraction", "explained_variance", "std", "at_bound_steering", "at_bound_speed", "return_scale",
    "reward_scale", "epochs",
)  # fmt: skip


def build_algorithm(
    env: gym.Env, network: str, hp: Hyperparameters, seed: int | None = None, device: str = "cpu"
) -> EpisodicPPO | EpisodicSAC:
    """The SB3 algorithm (PPO or SAC) for ``env`` with drx's ``network``, ready to collect episodes.

    :param env: the training environment (wrapped in a :class:`SingleVecEnv`).
    :param network: ``shallow``, ``deep`` or ``compact``.
    :param hp: DeepRacer hyperparameters.
    :param seed: random seed for the policy and sampling.
    :param device: the torch device it updates on, and samples on in this process (a resolved
        one, :func:`drx.train.device.resolve_device`; ``cuda``, ``cuda:1``, ``mps``, ``cpu``).
    """
    obs_space = env.observation_space
    venv = SingleVecEnv([lambda: env])
    policy = "MultiInputPolicy" if isinstance(obs_space, spaces.Dict) else "CnnPolicy"
    policy_kwargs: dict[str, Any] = {
        **policy_kwargs_for(network, obs_space),
        "optimizer_kwargs": hp.optimizer_kwargs(),
    }
    if hp.algorithm == "sac":
        if not isinstance(env.action_space, spaces.Box):
            raise DrxError("SAC trains continuous cars only; use --algo ppo for a car with discrete actions.")
        policy_kwargs["net_arch"] = {"pi": [64], "qf": [256]}
        replay: dict[str, Any] = {}
        if not isinstance(obs_space, spaces.Dict):  # frames stored pooled for the compact network
            replay = {"replay_buffer_class": PooledReplayBuffer,
                      "replay_buffer_kwargs": {"pool": input_pool(network, obs_space)}}  # fmt: skip
        model: EpisodicPPO | EpisodicSAC = EpisodicSAC(
            policy, venv, loss_type=hp.loss_type, policy_kwargs=policy_kwargs, seed=seed, device=device,
            verbose=0, **replay, **hp.sac_kwargs(),
        )  # fmt: skip
    else:
        # DeepRacer's heads sit directly on the network's last dense layer: on one trunk (drx's
        # default) or each on its own tower, as DeepRacer's network_0 (value) and network_1 (policy).
        policy_kwargs["net_arch"] = []
        policy_kwargs["share_features_extractor"] = hp.towers == "shared"
        model = EpisodicPPO(
            policy, venv, loss_type=hp.loss_type, initial_buffer_steps=INITIAL_BUFFER_STEPS,
            rollout_buffer_kwargs={"pool": input_pool(network, obs_space)},
            policy_kwargs=policy_kwargs, seed=seed, device=device, verbose=0, **hp.ppo_kwargs(),
        )  # fmt: skip
    setup(model)
    return model


def setup(model: BaseAlgorithm) -> None:
    """Prepare a model for :meth:`collect_episodes` / ``train()`` outside SB3's ``learn()``.

    Resets the environment, sets a silent logger whose recorded values the trainer reads.
    """
    model.set_logger(silent_logger())
    model._setup_learn(total_timesteps=2**62, callback=None, reset_num_timesteps=True)


def silent_logger() -> Logger:
    """An SB3 logger that writes nowhere (the trainer reads ``name_to_value``)."""
    return Logger(folder=None, output_formats=[])


def update_metrics(model: BaseAlgorithm) -> tuple[dict[str, float | None], dict[str, float]]:
    """The last update's figures, then clear them: (policy/value loss, entropy, KL, learning rate;
    the :data:`HEALTH_FIGURES` it recorded)."""
    values = dict(model.logger.name_to_value)
    model.logger.dump()
    health = {k: float(values[f"train/{k}"]) for k in HEALTH_FIGURES if f"train/{k}" in values}
    if isinstance(model, EpisodicSAC):
        return {
            "policy_loss": values.get("train/actor_loss"),
            "value_loss": values.get("train/critic_loss"),
            "entropy": None,
            "kl": None,
            "learning_rate": values.get("train/learning_rate"),
        }, health
    entropy_loss = values.get("train/entropy_loss")
    return {
        "policy_loss": values.get("train/policy_gradient_loss"),
        "value_loss": values.get("train/value_loss"),
        "entropy": -entropy_loss if entropy_loss is not None else None,
        "kl": values.get("train/approx_kl"),
        "learning_rate": values.get("train/learning_rate"),
    }, health


def set_progress(model: BaseAlgorithm, progress: float | None) -> None:
    """Tell SB3's schedules (the learning rate's) how far the run is, 0 to 1 (``None``: not
    known, so a schedule stays at its start). drx trains outside ``learn()``, whose progress
    would count toward :func:`setup`'s endless step budget."""
    model._current_progress_remaining = 1.0 - (progress or 0.0)


def update(model: EpisodicPPO | EpisodicSAC, buffered_steps: int, on_batch: BatchHook | None = None) -> bool:
    """One policy update after an iteration's episodes; False when ``on_batch`` cut it short."""
    if isinstance(model, EpisodicSAC):
        model.train(gradient_steps=max(1, buffered_steps), batch_size=model.batch_size, on_batch=on_batch)
    else:
        model.train(on_batch=on_batch)
    return not model.update_cut
