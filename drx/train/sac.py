"""SAC as DeepRacer runs it: N whole episodes (default 1), then as many gradient steps as steps taken.

:class:`EpisodicSAC` is SB3's ``SAC`` with a fixed entropy temperature (DeepRacer's
``sac_alpha``), episode-based collection through SB3's own off-policy rollout
loop, and a critic loss that is mean squared error (DeepRacer's SAC default) or Huber.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch as th
from stable_baselines3 import SAC
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.type_aliases import TrainFreq, TrainFrequencyUnit
from stable_baselines3.common.utils import polyak_update
from torch.nn import functional as F

from drx.train.ppo import BatchHook, Collected, StepHook


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


class EpisodicSAC(SAC):
    """SB3 SAC collecting whole episodes, with a Huber or MSE critic loss.

    :param loss_type: ``huber`` or ``mse`` for the critic loss.
    Other arguments are SB3's ``SAC`` arguments.
    """

    def __init__(self, *args: Any, loss_type: str = "mse", **kwargs: Any) -> None:
        self.loss_type = loss_type
        super().__init__(*args, **kwargs)

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
        """SB3's SAC update with the critic loss chosen by ``loss_type``.

        :param on_batch: asked before every gradient step with (1, 1); False ends the update there.
        """
        self.update_cut = False
        self.policy.set_training_mode(True)
        self._update_learning_rate([self.actor.optimizer, self.critic.optimizer])
        loss_fn = F.smooth_l1_loss if self.loss_type == "huber" else F.mse_loss
        ent_coef = self.ent_coef_tensor
        actor_losses, critic_losses = [], []
        for step in range(gradient_steps):
            if on_batch is not None and not on_batch(1, 1):
                self.update_cut = True
                gradient_steps = step
                break
            data = self.replay_buffer.sample(batch_size, env=self._vec_normalize_env)  # type: ignore[union-attr]
            actions_pi, log_prob = self.actor.action_log_prob(data.observations)
            log_prob = log_prob.reshape(-1, 1)
            with th.no_grad():
                next_actions, next_log_prob = self.actor.action_log_prob(data.next_observations)
                next_q = th.cat(self.critic_target(data.next_observations, next_actions), dim=1)
                next_q, _ = th.min(next_q, dim=1, keepdim=True)
                next_q = next_q - ent_coef * next_log_prob.reshape(-1, 1)
                target_q = data.rewards + (1 - data.dones) * self.gamma * next_q
            current_q = self.critic(data.observations, data.actions)
            critic_loss = 0.5 * sum(loss_fn(q, target_q) for q in current_q)
            assert isinstance(critic_loss, th.Tensor)
            critic_losses.append(critic_loss.item())
            self.critic.optimizer.zero_grad()
            critic_loss.backward()
            self.critic.optimizer.step()
            q_pi = th.cat(self.critic(data.observations, actions_pi), dim=1)
            min_q_pi, _ = th.min(q_pi, dim=1, keepdim=True)
            actor_loss = (ent_coef * log_prob - min_q_pi).mean()
            actor_losses.append(actor_loss.item())
            self.actor.optimizer.zero_grad()
            actor_loss.backward()
            self.actor.optimizer.step()
            if step % self.target_update_interval == 0:
                polyak_update(self.critic.parameters(), self.critic_target.parameters(), self.tau)
                polyak_update(self.batch_norm_stats, self.batch_norm_stats_target, 1.0)
        self._n_updates += gradient_steps
        self.logger.record("train/n_updates", self._n_updates)
        self.logger.record("train/ent_coef", float(ent_coef))
        self.logger.record("train/actor_loss", float(np.mean(actor_losses)) if actor_losses else 0.0)
        self.logger.record("train/critic_loss", float(np.mean(critic_losses)) if critic_losses else 0.0)
        self.logger.record("train/learning_rate", float(self.actor.optimizer.param_groups[0]["lr"]))
