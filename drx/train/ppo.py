"""PPO as DeepRacer runs it: an iteration is N whole episodes, then one update.

:class:`EpisodicPPO` is SB3's ``PPO`` with two changes:

- :meth:`EpisodicPPO.collect_episodes_driven` (in this process) and
  :meth:`EpisodicPPO.collect_episodes_parallel` (rollout workers) fill an
  :class:`EpisodeRolloutBuffer` with a given number of *whole* episodes, the same episodes
  either way, instead of a fixed number of steps;
- :meth:`EpisodicPPO.train` is SB3's update with the value loss DeepRacer lets
  the user choose: Huber (its default) or mean squared error;
- the three choices of :mod:`drx.train.stability` that keep thousands of updates stable:
  rewards divided by the running RMS of the return before GAE, a continuous policy's
  log-std capped at DeepRacer's starting 0, and a penalty on an action mean past the box.

Everything else (policy, clipping 0.2, GAE lambda 0.95, Adam eps 1e-5, advantage
normalisation, gradient clipping) is SB3's. The update computes what SB3's does, faster
(:attr:`EpisodicPPO.fast_update`): the frames divided by 255 once per update instead of once per
minibatch, each tower's network run once per minibatch, and drx's networks on their fast path
(:func:`drx.train.networks.use_fast_path`). Each update records the figures that tell a
healthy run from a dying one (``train/...``: entropy, approximate KL, clip fraction,
explained variance, the spread, the share of sampled actions on a bound, the return scale).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3 import PPO
from stable_baselines3.common.distributions import DiagGaussianDistribution
from stable_baselines3.common.preprocessing import is_image_space
from stable_baselines3.common.utils import explained_variance
from torch.nn import functional as F

from drx.train.buffer import EpisodeDictRolloutBuffer, EpisodeRolloutBuffer
from drx.train.networks import tune_malloc, use_fast_path
from drx.train.rate import AnnealedRate
from drx.train.rollout import EpisodeDriver, EpisodeSteps, RolloutWorkers
from drx.train.stability import BOUND_LOSS_COEF, ReturnScale, bound_loss, cap_log_std

# Called after every environment step with (action, reward, done, info); False stops collection.
StepHook = Callable[[np.ndarray, float, bool, dict[str, Any]], bool]
# Called before every minibatch of an update with (epoch, epochs), both 1-based; False ends the
# update there (the minibatches already applied stay applied).
BatchHook = Callable[[int, int], bool]


def at_bound_shares(actions: np.ndarray) -> list[float]:
    """Per action dimension, the share of sampled (unclipped) actions on or past a bound of the
    normalised box [-1, 1]: how much of a continuous policy's exploration drives a bound."""
    a = np.asarray(actions, dtype=np.float64).reshape(len(actions), -1)
    return [float(np.mean(np.abs(a[:, k]) >= 1.0)) if len(a) else 0.0 for k in range(a.shape[1])]


@dataclass
class Collected:
    """What one collection of whole episodes gathered (:meth:`EpisodicPPO.collect_episodes_driven`,
    :meth:`~EpisodicPPO.collect_episodes_parallel`, :meth:`drx.train.sac.EpisodicSAC.collect_episodes`).

    :param steps: environment steps taken (including those of a cut, unfinished episode).
    :param episodes: whole episodes collected.
    :param buffered_steps: steps kept for the update (those of whole episodes).
    :param interrupted: the step hook asked to stop before the episodes were complete.
    """

    steps: int
    episodes: int
    buffered_steps: int
    interrupted: bool


class EpisodicPPO(AnnealedRate, PPO):
    """SB3 PPO whose rollouts are whole episodes and whose value loss may be Huber.

    :param loss_type: ``huber`` or ``mse`` for the value loss.
    :param initial_buffer_steps: room the rollout buffer starts with (it grows as needed).
    :param fast_update: compute the update the fast way (the same numbers to float rounding);
        False computes it as SB3 does, for comparison (tests/train/test_update_equivalence.py,
        benchmarks/update_speed.py). ``None``: fast unless the environment says
        ``DRX_FAST_UPDATE=0``.
    Other arguments are SB3's ``PPO`` arguments.
    """

    def __init__(
        self,
        *args: Any,
        loss_type: str = "huber",
        initial_buffer_steps: int = 2048,
        fast_update: bool | None = None,
        **kwargs: Any,
    ):
        env = kwargs.get("env", args[1] if len(args) > 1 else None)
        obs_space = getattr(env, "observation_space", None)
        buffer_class = (
            EpisodeDictRolloutBuffer if isinstance(obs_space, spaces.Dict) else EpisodeRolloutBuffer
        )
        kwargs.setdefault("rollout_buffer_class", buffer_class)
        kwargs.setdefault("n_steps", initial_buffer_steps)
        self.loss_type = loss_type
        if fast_update is None:
            fast_update = os.environ.get("DRX_FAST_UPDATE", "1") != "0"
        self.fast_update = fast_update
        tune_malloc()
        self.return_scale = ReturnScale()
        super().__init__(*args, **kwargs)

    def _excluded_save_params(self) -> list[str]:
        """SB3's, and :attr:`fast_update`: how this process computes updates, not the model's state."""
        return [*super()._excluded_save_params(), "fast_update"]

    def rate_optimizers(self) -> list[th.optim.Optimizer]:
        """The policy's optimizer (the rate :class:`~drx.train.rate.AnnealedRate` sets)."""
        return [self.policy.optimizer]

    @property
    def bootstrap_factor(self) -> float:
        """What a time-up ending's final value is multiplied by to join its last reward: the discount,
        times the return scale (the value head predicts returns in units of it, the reward is raw)."""
        return self.gamma * (self.return_scale.rms or 1.0)

    def collect_episodes_parallel(
        self,
        workers: RolloutWorkers,
        n_episodes: int,
        first_episode: int,
        on_step: StepHook | None = None,
        keep_going: Callable[[], bool] | None = None,
    ) -> Collected:
        """Run the current policy for ``n_episodes`` whole episodes, driven by ``workers`` (each has
        the policy), into the rollout buffer; call :meth:`train` afterwards when ``buffered_steps > 0``.

        The workers get the current weights once; episode ``first_episode + i`` (``i <
        n_episodes``) starts where DeepRacer's round robin puts it
        (:func:`drx.train.rollout.start_fraction`) on whichever worker is free next, which drives
        it whole and sends it back in one message. Finished episodes go to the buffer and
        through ``on_step`` in episode order, step by step, exactly as one worker would have
        produced them; when ``on_step`` or ``keep_going`` (asked every
        :data:`drx.train.rollout.POLL_SECONDS` while the workers drive) says stop, the episodes
        not yet handed on are dropped.

        :param workers: the rollout workers.
        :param n_episodes: episodes to collect.
        :param first_episode: the model's running number of the first one (the round robin's position).
        :param on_step: called for every step of every finished episode, in episode order.
        :param keep_going: asked while waiting for the workers; False stops the collection.
        """
        buffer = self.rollout_buffer
        assert isinstance(buffer, EpisodeRolloutBuffer | EpisodeDictRolloutBuffer)
        self.policy.set_training_mode(False)
        buffer.reset()
        end = first_episode + n_episodes
        finished: dict[int, EpisodeSteps] = {}
        next_episode = handed = first_episode
        steps = episodes = boundary = 0
        stopped = False
        try:
            workers.set_policy(self.policy, self.bootstrap_factor)
            for k in range(workers.count):
                if next_episode < end:
                    workers.start(k, next_episode)
                    next_episode += 1
            while handed < end and not stopped:
                for k, episode, episode_steps in workers.finished():
                    finished[episode] = episode_steps
                    steps += len(episode_steps)
                    if next_episode < end:
                        workers.start(k, next_episode)
                        next_episode += 1
                while handed in finished and not stopped:
                    ep = finished.pop(handed)
                    last = len(ep) - 1
                    for i in range(len(ep)):
                        reward = float(ep.rewards[i])
                        self._add_step(
                            ep.observation(i), ep.actions[i], reward, i == 0, ep.values[i], ep.log_probs[i]
                        )
                        if i == last:
                            episodes += 1
                            boundary = buffer.pos
                        if on_step is not None and not on_step(
                            ep.env_actions[i], reward, i == last, ep.infos[i]
                        ):
                            stopped = True
                            break
                    handed += 1
                if keep_going is not None and not keep_going():
                    stopped = True
            workers.abort()
        except BaseException:
            workers.close()  # a worker left mid-message cannot be trusted with the next iteration
            raise
        return self._close_buffer(boundary, steps, episodes, n_episodes)

    def collect_episodes_driven(
        self,
        env: gym.Env,
        n_episodes: int,
        first_episode: int,
        seed: int | None,
        on_step: StepHook | None = None,
    ) -> Collected:
        """Like :meth:`collect_episodes_parallel` with one worker in this process: the same episodes.

        Episode ``first_episode + i`` starts where DeepRacer's round robin puts it and, with a
        ``seed``, is seeded from ``(seed, episode)`` (:class:`drx.train.rollout.EpisodeDriver`, as
        in a rollout worker; torch's global generator is restored afterwards), so a seeded run
        writes the same trace and episode rows whatever the number of workers. Each step goes to
        the buffer and ``on_step`` as it happens; when ``on_step`` says stop the collection ends
        there (the unfinished episode's steps are counted, not buffered).

        :param env: the training environment (not vectorised).
        :param n_episodes: episodes to collect.
        :param first_episode: the model's running number of the first one (the round robin's position).
        :param seed: the run's seed (``None``: unseeded).
        :param on_step: called after every step; return False to stop.
        """
        buffer = self.rollout_buffer
        assert isinstance(buffer, EpisodeRolloutBuffer | EpisodeDictRolloutBuffer)
        buffer.reset()
        driver = EpisodeDriver(self.policy, self.bootstrap_factor)
        steps = episodes = boundary = 0
        stopped = False
        with th.random.fork_rng(devices=[]):
            for episode in range(first_episode, first_episode + n_episodes):
                first = True
                for row, action, env_action, reward, value, log_prob, info, done in driver.steps(
                    env, episode, seed
                ):
                    self._add_step(
                        row[None] if not isinstance(row, dict) else {k: v[None] for k, v in row.items()},
                        action,
                        reward,
                        first,
                        value,
                        log_prob,
                    )
                    first = False
                    steps += 1
                    if done:
                        episodes += 1
                        boundary = buffer.pos
                    if on_step is not None and not on_step(env_action, reward, done, info):
                        stopped = True
                        break
                if stopped:
                    break
        return self._close_buffer(boundary, steps, episodes, n_episodes)

    def _close_buffer(self, boundary: int, steps: int, episodes: int, n_episodes: int) -> Collected:
        """Keep the buffer's whole episodes (up to ``boundary``) and compute their advantages.

        Every episode in it ended (a time-up ending's bootstrap is already in its last reward).
        """
        buffer = self.rollout_buffer
        assert isinstance(buffer, EpisodeRolloutBuffer | EpisodeDictRolloutBuffer)
        buffer.pos = boundary
        if boundary > 0:
            rewards = buffer.rewards[:boundary, 0]
            buffer.rewards[:boundary, 0] = self.return_scale.scale_rewards(
                rewards, buffer.episode_starts[:boundary, 0], self.gamma
            )
            buffer.finish(last_values=th.zeros(1), dones=np.ones(1, dtype=bool))
        return Collected(
            steps=steps, episodes=episodes, buffered_steps=boundary, interrupted=episodes < n_episodes
        )

    def _add_step(
        self, obs: Any, action: np.ndarray, reward: float, first: bool, value: float, log_prob: float
    ) -> None:
        """One driven step into the rollout buffer (``obs`` with a leading axis of one)."""
        action = np.asarray(action).reshape(1, -1)  # SB3's buffer keeps (1, action_dim), discrete too
        self.rollout_buffer.add(
            obs, action, np.array([reward]), np.array([first]),  # type: ignore[arg-type]
            th.tensor([value]), th.tensor([log_prob]),
        )  # fmt: skip
        self.num_timesteps += 1

    def _frame_keys(self) -> list[str] | None:
        """The observations (keys; ``""`` for an array) SB3's policy divides by 255 (its frames), or
        ``None`` when its preprocessing does more than that and a float conversion (discrete
        observations, which it one-hot encodes)."""
        space = self.observation_space
        subspaces = dict(space.spaces) if isinstance(space, spaces.Dict) else {"": space}
        if not all(isinstance(s, spaces.Box) for s in subspaces.values()):
            return None
        normalize = bool(self.policy.normalize_images)
        return [key for key, s in subspaces.items() if normalize and is_image_space(s)]

    def _evaluate_actions(
        self, obs: Any, actions: th.Tensor, preprocessed: bool = False, fast: bool = False
    ) -> tuple[th.Tensor, th.Tensor, th.Tensor | None, th.Tensor | None]:
        """SB3's ``evaluate_actions`` (values, log-probabilities, entropy) plus the Gaussian's mean of a
        continuous policy (``None`` for a discrete one).

        :param preprocessed: ``obs`` is already as SB3's ``preprocess_obs`` makes it (frames in [0, 1]).
        :param fast: run each tower once; otherwise separate towers are run SB3's way, the policy
            tower twice (``evaluate_actions``, then ``get_distribution`` for the mean).
        """
        policy = self.policy
        if not policy.share_features_extractor and not fast:
            values, log_prob, entropy = policy.evaluate_actions(obs, actions)
            gaussian = policy.get_distribution(obs)
            mean = gaussian.distribution.mean if isinstance(gaussian, DiagGaussianDistribution) else None
            return values, log_prob, entropy, mean
        if preprocessed:
            if policy.share_features_extractor:
                features: Any = policy.features_extractor(obs)
            else:
                features = (policy.pi_features_extractor(obs), policy.vf_features_extractor(obs))
        else:
            features = policy.extract_features(obs)
        if policy.share_features_extractor:  # drx's default: both heads on one trunk
            latent_pi, latent_vf = policy.mlp_extractor(features)
        else:  # DeepRacer's two towers
            latent_pi = policy.mlp_extractor.forward_actor(features[0])
            latent_vf = policy.mlp_extractor.forward_critic(features[1])
        distribution = policy._get_action_dist_from_latent(latent_pi)
        log_prob = distribution.log_prob(actions)
        values = policy.value_net(latent_vf)
        mean = None
        if isinstance(distribution, DiagGaussianDistribution):
            mean = distribution.distribution.mean
        return values, log_prob, distribution.entropy(), mean

    def train(self, on_batch: BatchHook | None = None) -> None:
        """One policy update over the buffer: SB3's PPO step with a Huber or MSE value loss.

        :param on_batch: asked before every minibatch; when it returns False the update ends
            there (:attr:`update_cut` then says so), e.g. at a time limit.
        """
        self.update_cut = False
        self.policy.set_training_mode(True)
        use_fast_path(self.policy, self.fast_update)
        buffer = self.rollout_buffer
        assert isinstance(buffer, EpisodeRolloutBuffer | EpisodeDictRolloutBuffer)
        # The fast update has the buffer divide the frames (once per update for pooled ones) and
        # hand them out as tensors, so that the policy reads them without its own preprocessing.
        keys = self._frame_keys() if self.fast_update else None
        preprocessed = keys is not None
        frames: AbstractContextManager[None] = (
            buffer.divided_frames(255.0, keys) if keys is not None else nullcontext()
        )
        self._update_learning_rate(self.policy.optimizer)
        clip_range = self.clip_range(self._current_progress_remaining)  # type: ignore[operator]
        value_loss_fn = F.smooth_l1_loss if self.loss_type == "huber" else F.mse_loss
        entropy_losses, pg_losses, value_losses, clip_fractions, approx_kls = [], [], [], [], []
        loss = th.zeros(())
        continuous = isinstance(self.action_space, spaces.Box)
        epochs_run = 0
        with frames:
            for epoch in range(self.n_epochs):
                epochs_run = epoch + 1
                for data in self.rollout_buffer.get(self.batch_size):
                    if on_batch is not None and not on_batch(epoch + 1, self.n_epochs):
                        self.update_cut = True
                        break
                    actions = data.actions
                    if isinstance(self.action_space, spaces.Discrete):
                        actions = data.actions.long().flatten()
                    values, log_prob, entropy, mean = self._evaluate_actions(
                        data.observations, actions, preprocessed, self.fast_update
                    )
                    values = values.flatten()
                    advantages = data.advantages
                    if self.normalize_advantage and len(advantages) > 1:
                        advantages = (advantages - advantages.mean()) / (advantages.std() + 1e-8)
                    ratio = th.exp(log_prob - data.old_log_prob)
                    policy_loss = -th.min(
                        advantages * ratio, advantages * th.clamp(ratio, 1 - clip_range, 1 + clip_range)
                    ).mean()
                    value_loss = value_loss_fn(values, data.returns)
                    entropy_loss = -th.mean(-log_prob) if entropy is None else -th.mean(entropy)
                    loss = policy_loss + self.ent_coef * entropy_loss + self.vf_coef * value_loss
                    if mean is not None:
                        loss = loss + BOUND_LOSS_COEF * bound_loss(mean)
                    with th.no_grad():
                        log_ratio = log_prob - data.old_log_prob
                        approx_kls.append(float(th.mean((th.exp(log_ratio) - 1) - log_ratio)))
                        clip_fractions.append(float(th.mean((th.abs(ratio - 1) > clip_range).float())))
                    pg_losses.append(policy_loss.item())
                    value_losses.append(value_loss.item())
                    entropy_losses.append(entropy_loss.item())
                    self.policy.optimizer.zero_grad()
                    loss.backward()
                    th.nn.utils.clip_grad_norm_(self.policy.parameters(), self.max_grad_norm)
                    self.policy.optimizer.step()
                    if continuous:
                        cap_log_std(self.policy.log_std)
                self._n_updates += 1
                if self.update_cut:
                    break
        if not pg_losses:  # cut before its first minibatch: nothing to report
            return
        self.logger.record("train/entropy_loss", float(np.mean(entropy_losses)))
        self.logger.record("train/policy_gradient_loss", float(np.mean(pg_losses)))
        self.logger.record("train/value_loss", float(np.mean(value_losses)))
        self.logger.record("train/approx_kl", float(np.mean(approx_kls)))
        self.logger.record("train/clip_fraction", float(np.mean(clip_fractions)))
        self.logger.record("train/loss", loss.item())
        self.logger.record(
            "train/explained_variance",
            float(explained_variance(buffer.values.flatten(), buffer.returns.flatten())),
        )
        self.logger.record("train/learning_rate", float(self.policy.optimizer.param_groups[0]["lr"]))
        if hasattr(self.policy, "log_std"):
            self.logger.record("train/std", th.exp(self.policy.log_std).mean().item())
        self.logger.record("train/n_updates", self._n_updates)
        self.logger.record("train/epochs", epochs_run)
        self.logger.record("train/return_scale", self.return_scale.rms or 1.0)
        if continuous:
            for name, share in zip(("steering", "speed"), at_bound_shares(buffer.actions), strict=True):
                self.logger.record(f"train/at_bound_{name}", share)
