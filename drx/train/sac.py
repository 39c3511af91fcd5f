"""SAC as DeepRacer runs it: N whole episodes (default 1), then as many gradient steps as steps taken.

:class:`EpisodicSAC` is SB3's ``SAC`` with a fixed entropy temperature (DeepRacer's
``sac_alpha``), episode-based collection through SB3's own off-policy rollout loop, and a
critic loss that is mean squared error (DeepRacer's SAC default) or Huber. One gradient step
per environment step is DeepRacer's rule (deepracer-simapp ``markov/training_worker.py`` sets
``num_consecutive_training_steps`` to the rollout's steps).

Two named choices make it train in minutes where SB3's SAC did not lap in ten (issue 23,
``docs/TRAINING.md``):

**The rewards reach the critics in units of their running root-mean-square a step**
(:class:`drx.train.stability.RewardScale`). SAC's temperature weighs the policy's entropy
against the reward of one step, so ``sac_alpha = 0.2`` (DeepRacer's default) means what it
says only for a reward of about 1 a step, which DeepRacer's example rewards pay. The "pursuit"
reward pays 50-120 a step, which left the entropy term a few thousandths of the critics' values.
On A to Z Speedway (``benchmarks/race_pace.py --algo sac --only exp2 --minutes 10``, the code
before and after side by side) SB3's SAC on the raw rewards never evaluated 3/3 and its best
checkpoint lapped in 26.0 s with 28 off-tracks; with the rewards divided by their running RMS
(an exponential average over iterations, kept in the checkpoint) the run lapped 3/3 from
iteration 261 and its best checkpoint laps in 7.40 s with none. A reward that already pays
about 1 a step is left about as it is.

**One camera encoder, trained by the critic** (:meth:`EpisodicSAC.train`): the rule of
pixel-based SAC (SAC-AE, Yarats et al. 2019; DrQ), and a cheaper gradient step than SB3's
separate actor and critic encoders (``benchmarks/sac_update.py``): the same 10 minutes above
trained 19,049 steps where SB3's update allowed 10,799. The actor's loss computes no gradient
for the critics' heads (the next critic step zeroed them), the target follows by one
``torch._foreach_lerp_`` and ``predict`` no longer walks every module to set a mode already set:
the same numbers, fewer milliseconds. Target critics that are heads on the online encoder's
features (DrQ-v2) cut a gradient step's time by about a fifth, but in a 10-minute race-pace run
beside the code before it the last checkpoint lapped 11.74 s with 5 off-tracks against the best's
7.47, where the code before held 8.53 against 7.33: not kept (``docs/TRAINING.md``).

**Why SAC stays near a tenth of PPO's steps per minute.** One gradient step per environment step
is DeepRacer's rule (the comment in simapp's ``training_worker.py``: "you can train even more
iterations than rollout_steps by increasing the number below for SAC"), and a step on a batch of
128 frames is compute-bound on a CPU core: encoding the batch (three passes forward, one backward
through 2 convolutions and a 1120x128 dense layer) is ~0.5 GFLOP, 75 % of the step's time in
``aten`` matrix and convolution kernels at ~50 GFLOP/s (torch.profiler, ``benchmarks/sac_update.py``).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch as th
from stable_baselines3 import SAC
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.distributions import SquashedDiagGaussianDistribution
from stable_baselines3.common.policies import ContinuousCritic
from stable_baselines3.common.type_aliases import ReplayBufferSamples, TrainFreq, TrainFrequencyUnit
from stable_baselines3.sac.policies import LOG_STD_MAX, LOG_STD_MIN, SACPolicy
from torch.nn import functional as F

from drx.train.ppo import BatchHook, Collected, StepHook
from drx.train.rate import AnnealedRate
from drx.train.stability import RewardScale

AT_BOUND = 0.99  # |squashed action| past which a sample counts as on a bound of the box


class _HookCallback(BaseCallback):
    """Adapts a :data:`StepHook` to SB3's callback interface."""

    def __init__(self, hook: StepHook | None) -> None:
        super().__init__()
        self.hook = hook
        self.steps = 0
        self.episodes = 0

    def _on_step(self) -> bool:
        self.steps += 1
        done = bool(self.locals["dones"][0])
        self.episodes += int(done)
        if self.hook is None:
            return True
        return self.hook(
            self.locals["actions"][0], float(self.locals["rewards"][0]), done, self.locals["infos"][0]
        )


class EpisodicSAC(AnnealedRate, SAC):
    """SB3 SAC collecting whole episodes, with a Huber or MSE critic loss.

    :param loss_type: ``huber`` or ``mse`` for the critic loss.
    :param scale_rewards: divide rewards by their running root-mean-square a step
        (:attr:`reward_scale`, see the module docstring); False trains on the raw rewards.
    Other arguments are SB3's ``SAC`` arguments.
    """

    def __init__(self, *args: Any, loss_type: str = "mse", scale_rewards: bool = True, **kwargs: Any) -> None:
        self.loss_type = loss_type
        self.scale_rewards = scale_rewards
        self.reward_scale = RewardScale()
        super().__init__(*args, **kwargs)
        assert not self.policy.share_features_extractor, "drx's SAC trains the critic's encoder itself"
        self.sync_actor_encoder()  # the first episodes see the encoder the update trains

    def rate_optimizers(self) -> list[th.optim.Optimizer]:
        """The actor's and the critic's optimizers (the rate :class:`~drx.train.rate.AnnealedRate` sets)."""
        return [self.actor.optimizer, self.critic.optimizer]

    def collect_episodes(self, n_episodes: int, on_step: StepHook | None = None) -> Collected:
        """Run the current policy for ``n_episodes`` whole episodes into the replay buffer.

        :param n_episodes: episodes to collect.
        :param on_step: called after every step; return False to stop.
        """
        assert self.env is not None and self.replay_buffer is not None, (
            "call setup() before collect_episodes()"
        )
        callback = _HookCallback(on_step)
        callback.init_callback(self)
        result = self.collect_rollouts(
            self.env,
            callback,
            TrainFreq(n_episodes, TrainFrequencyUnit.EPISODE),
            self.replay_buffer,
            learning_starts=0,
            log_interval=None,
        )
        interrupted = not result.continue_training and result.n_episodes < n_episodes
        kept = result.episode_timesteps if not interrupted else callback.steps - 1
        return Collected(
            steps=callback.steps,
            episodes=result.n_episodes,
            buffered_steps=max(0, kept),
            interrupted=interrupted,
        )

    def train(self, gradient_steps: int, batch_size: int = 64, on_batch: BatchHook | None = None) -> None:
        """SAC's update, with one camera encoder that the critic's loss trains.

        Each gradient step is SB3's SAC step (twin critics, fixed ``ent_coef``, Polyak-averaged
        target, the critic loss chosen by ``loss_type``) but for two things. The rewards are
        divided by :attr:`reward_scale` (when ``scale_rewards``). And the camera features come
        from the critic's encoder, which the actor reads detached, so only the critic's loss
        moves the convolutions: the encoder rule of pixel-based SAC (SAC-AE, Yarats et al. 2019:
        the actor's gradient through the encoder hurts; DrQ keeps the rule). A step runs the
        encoder forward three times and backward once (:meth:`_critic_step`), where SB3's separate
        actor and critic encoders take five and three. The actor's own encoder module is kept (checkpoints,
        evaluation and exports read the actor alone) and gets the critic's weights at the end
        of every update (:meth:`sync_actor_encoder`).

        :param on_batch: asked before every gradient step with (1, 1); False ends the update there.
        """
        assert not self.actor.use_sde, "drx's SAC samples with a plain squashed Gaussian, not gSDE"
        self.update_cut = False
        self.policy.set_training_mode(True)
        self._update_learning_rate(self.rate_optimizers())
        if self.scale_rewards:
            self.reward_scale.update(self._newest_rewards(gradient_steps))
        scale = self.reward_scale.value if self.scale_rewards else 1.0
        actor_losses, critic_losses, log_stds, at_bound = [], [], [], []
        for step in range(gradient_steps):
            if on_batch is not None and not on_batch(1, 1):
                self.update_cut = True
                gradient_steps = step
                break
            data = self.replay_buffer.sample(batch_size, env=self._vec_normalize_env)  # type: ignore[union-attr]
            features, critic_loss = self._critic_step(data, scale)
            actor_loss, log_std, actions = self._actor_step(features)
            critic_losses.append(critic_loss)
            actor_losses.append(actor_loss)
            log_stds.append(log_std)
            at_bound.append((actions.abs() > AT_BOUND).float().mean(dim=0))
            if step % self.target_update_interval == 0:
                with th.no_grad():
                    th._foreach_lerp_(self._target_params, self._online_params, self.tau)
        self.sync_actor_encoder()
        self._n_updates += gradient_steps
        self.logger.record("train/n_updates", self._n_updates)
        self.logger.record("train/ent_coef", float(self.ent_coef_tensor))
        self.logger.record("train/actor_loss", float(np.mean(actor_losses)) if actor_losses else 0.0)
        self.logger.record("train/critic_loss", float(np.mean(critic_losses)) if critic_losses else 0.0)
        if log_stds:
            self.logger.record("train/std", float(np.exp(np.mean(log_stds))))
            shares = th.stack(at_bound).mean(dim=0).cpu().numpy()
            self.logger.record("train/at_bound_steering", float(shares[0]))
            self.logger.record("train/at_bound_speed", float(shares[-1]))
        self.logger.record("train/reward_scale", scale)
        self.logger.record("train/learning_rate", float(self.actor.optimizer.param_groups[0]["lr"]))

    def _critic_step(self, data: ReplayBufferSamples, scale: float) -> tuple[th.Tensor, float]:
        """One step of the critics (and their encoder) on a batch; the batch's features (detached)
        and the loss.

        The next observations are encoded by the online encoder for the actor's next action and by
        the target's, Polyak-averaged, for the target critics (SAC-AE's and DrQ's targets).

        :param scale: what the rewards are divided by.
        """
        critic, target = self.critic, self.critic_target
        features = critic.extract_features(data.observations, critic.features_extractor)
        with th.no_grad():
            next_online = critic.extract_features(data.next_observations, critic.features_extractor)
            next_actions, next_log_prob, _ = self._actor_on(next_online)
            next_features = target.extract_features(data.next_observations, target.features_extractor)
            next_q = _min_q(target, next_features, next_actions) - self.ent_coef_tensor * next_log_prob
            discounts = data.discounts if data.discounts is not None else self.gamma  # SB3's n-step replay
            target_q = data.rewards / scale + (1 - data.dones) * discounts * next_q
        loss_fn = F.smooth_l1_loss if self.loss_type == "huber" else F.mse_loss
        loss = 0.5 * sum(loss_fn(q, target_q) for q in _q_values(critic, features, data.actions))
        assert isinstance(loss, th.Tensor)
        critic.optimizer.zero_grad()
        loss.backward()
        critic.optimizer.step()
        return features.detach(), loss.item()

    def _actor_step(self, features: th.Tensor) -> tuple[float, float, th.Tensor]:
        """One step of the actor's head on detached encoder features: its loss, mean log-std and
        the squashed actions it sampled.

        The critics' heads are held without a gradient while the actor's loss runs back through
        them to the actions: SB3 lets the loss fill the critics' gradients, which the next
        critic step zeroes before use, so skipping them changes no number and saves two
        matrix products a layer."""
        actions, log_prob, log_std = self._actor_on(features)
        for param in self._online_heads:
            param.requires_grad_(False)
        try:
            loss = (self.ent_coef_tensor * log_prob - _min_q(self.critic, features, actions)).mean()
            self.actor.optimizer.zero_grad()
            loss.backward()
        finally:
            for param in self._online_heads:
                param.requires_grad_(True)
        self.actor.optimizer.step()
        return loss.item(), log_std.detach().mean().item(), actions.detach()

    def _newest_rewards(self, n: int) -> np.ndarray:
        """The rewards of the last ``n`` transitions added to the replay buffer."""
        buffer = self.replay_buffer
        assert buffer is not None
        n = min(n, buffer.buffer_size if buffer.full else buffer.pos)
        indices = (buffer.pos - 1 - np.arange(n)) % buffer.buffer_size
        return np.asarray(buffer.rewards[indices], dtype=np.float64).ravel()

    def _actor_on(self, features: th.Tensor) -> tuple[th.Tensor, th.Tensor, th.Tensor]:
        """The actor's squashed sample, its log-probability ``(batch, 1)`` and log-std, from encoder
        features."""
        # SB3's Actor.get_action_dist_params and action_log_prob, from features already extracted.
        latent = self.actor.latent_pi(features)
        mean = self.actor.mu(latent)
        log_std = th.clamp(self.actor.log_std(latent), LOG_STD_MIN, LOG_STD_MAX)  # type: ignore[operator]
        dist = self.actor.action_dist
        assert isinstance(dist, SquashedDiagGaussianDistribution)
        actions, log_prob = dist.log_prob_from_params(mean, log_std)
        return actions, log_prob.reshape(-1, 1), log_std

    def _setup_model(self) -> None:
        super()._setup_model()
        # The Q heads (the actor's loss holds them without a gradient) and every critic parameter,
        # online and target in the same order, for the Polyak average (SB3's polyak_update's pairs).
        self._online_heads = [p for q in self.critic.q_networks for p in q.parameters()]
        self._online_params: list[th.Tensor] = list(self.critic.parameters())
        self._target_params: list[th.Tensor] = list(self.critic_target.parameters())
        _skip_unchanged_mode(self.policy)

    def sync_actor_encoder(self) -> None:
        """Give the actor's encoder the critic's weights (the one the update trains)."""
        self.actor.features_extractor.load_state_dict(self.critic.features_extractor.state_dict())

    def adopt_actor_encoder(self) -> None:
        """Give the critic and its target the actor's encoder: for a checkpoint written before
        drx's SAC shared one encoder, whose actor head was trained on the actor's own encoder.
        The policy drives as it did; the critics' heads adapt to the encoder in the next updates."""
        weights = self.actor.features_extractor.state_dict()
        self.critic.features_extractor.load_state_dict(weights)
        self.critic_target.features_extractor.load_state_dict(weights)


def _skip_unchanged_mode(policy: SACPolicy) -> None:
    """Make ``policy.set_training_mode`` return at once when the actor and critic are already in
    that mode. SB3's ``predict`` sets the mode on every call, once an environment step, and each
    call walks every module: 7% of a SAC run's time on 2 cores (cProfile of a 60 s run, 650,000
    ``Module.train`` calls for 17,000 steps). drx's networks hold no dropout or batch norm, so the
    mode changes nothing they compute; the walk is kept for a real change of mode."""
    walk = policy.set_training_mode

    def set_training_mode(mode: bool) -> None:
        if policy.training == mode and policy.actor.training == mode and policy.critic.training == mode:
            return
        walk(mode)

    policy.set_training_mode = set_training_mode  # type: ignore[method-assign]


def _q_values(critic: ContinuousCritic, features: th.Tensor, actions: th.Tensor) -> list[th.Tensor]:
    """The critic's Q-values from already extracted features (its encoder not run again)."""
    q_input = th.cat([features, actions], dim=1)
    return [q_net(q_input) for q_net in critic.q_networks]


def _min_q(critic: ContinuousCritic, features: th.Tensor, actions: th.Tensor) -> th.Tensor:
    """The smaller of the twin critics' Q-values, ``(batch, 1)``."""
    return th.min(th.cat(_q_values(critic, features, actions), dim=1), dim=1, keepdim=True).values
