"""Registers drx's Gymnasium environments; :mod:`drx` calls :func:`register_envs` on import."""

from __future__ import annotations

import gymnasium as gym

ENV_ID = "drx/DeepRacer-v0"


def register_envs() -> None:
    """Register ``drx/DeepRacer-v0`` (idempotent)."""
    if ENV_ID not in gym.registry:
        gym.register(id=ENV_ID, entry_point="drx.sim.env:DeepRacerEnv")
