"""A one-environment ``VecEnv`` without SB3's per-step deep copy of ``info``.

SB3's ``DummyVecEnv`` deep-copies every step's infos; drx's infos carry the
reward ``params`` with the track's waypoint list, and that copy alone costs more
than the simulator step. drx's env builds a fresh info dict every step and
nothing downstream mutates it, so sharing it is safe.
"""

from __future__ import annotations

import numpy as np
from stable_baselines3.common.vec_env import DummyVecEnv
from stable_baselines3.common.vec_env.base_vec_env import VecEnvStepReturn


class SingleVecEnv(DummyVecEnv):
    """``DummyVecEnv`` that returns its info dicts as they are."""

    def step_wait(self) -> VecEnvStepReturn:
        """Step every env (auto-resetting finished ones) without copying infos."""
        for i in range(self.num_envs):
            obs, rew, terminated, truncated, info = self.envs[i].step(self.actions[i])
            self.buf_rews[i] = rew
            self.buf_dones[i] = terminated or truncated
            info["TimeLimit.truncated"] = truncated and not terminated
            if self.buf_dones[i]:
                info["terminal_observation"] = obs
                obs, self.reset_infos[i] = self.envs[i].reset()
            self._save_obs(i, obs)
            self.buf_infos[i] = info
        return self._obs_from_buf(), np.copy(self.buf_rews), np.copy(self.buf_dones), list(self.buf_infos)
