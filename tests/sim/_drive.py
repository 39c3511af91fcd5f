"""A pure-pursuit driver for tests: follows the centre line (or drives it backwards)."""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym

from drx.sim.dynamics import steering_for_curvature
from drx.vehicle import Vehicle

CONTINUOUS = Vehicle(name="test", continuous=True, steering_range=(-30.0, 30.0), speed_range=(0.5, 4.0))


def make(track: Any, **kwargs: Any) -> gym.Env:
    """The env with a continuous car (so tests can command any steering and speed); without the
    simulator's step-time noise unless a test asks for it (``deterministic=False``), so tests of the
    rules repeat exactly."""
    kwargs.setdefault("vehicle", CONTINUOUS)
    kwargs.setdefault("deterministic", True)
    return gym.make("drx/DeepRacer-v0", track=track, **kwargs)


def action(steer_deg: float, speed: float) -> list[float]:
    """Continuous action in [-1, 1]^2 for ``CONTINUOUS``."""
    return [steer_deg / 30.0, (speed - 2.25) / 1.75]


def pursuit_steering(env: gym.Env, lookahead: float = 0.45, backwards: bool = False) -> float:
    """Steering [deg] that aims the rear axle at the centre-line point ``lookahead`` m ahead (through
    the car model's inverse steering, as drx's scripted drivers do)."""
    e = env.unwrapped
    st, track = e.car_state, e.track
    s = track.project(st.x, st.y).s
    tx, ty = track.point_at(s - lookahead if backwards else s + lookahead)
    alpha = math.atan2(ty - st.y, tx - st.x) - st.yaw
    alpha = (alpha + math.pi) % (2 * math.pi) - math.pi
    dist = max(math.hypot(tx - st.x, ty - st.y), 1e-6)
    delta = steering_for_curvature(2.0 * math.sin(alpha) / dist, st.speed, e.car)
    return max(-30.0, min(30.0, math.degrees(delta)))


def drive(
    env: gym.Env, speed: float, max_steps: int = 5000, backwards: bool = False, steer: float | None = None
) -> tuple[list[dict], list[float]]:
    """Drive until the episode ends; returns the infos and the steering commands [deg]."""
    infos, steers = [], []
    for _ in range(max_steps):
        cmd = steer if steer is not None else pursuit_steering(env, backwards=backwards)
        steers.append(cmd)
        _, _, terminated, truncated, info = env.step(action(cmd, speed))
        infos.append(info)
        if terminated or truncated:
            break
    return infos, steers
