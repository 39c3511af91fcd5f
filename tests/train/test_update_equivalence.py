"""drx's fast PPO update computes what SB3's way of computing it does, to float rounding.

Two models, built alike from the same seed, get the same buffer of steps; one updates the fast way
(:attr:`drx.train.ppo.EpisodicPPO.fast_update`: frames divided once per update, each tower run
once per minibatch, the networks' fast path of :mod:`drx.train.networks`), the other as SB3
computes it (its buffer's minibatches and preprocessing, its ``evaluate_actions``, torch's
default kernels). Their gradients on one minibatch, and their parameters after a few
minibatches, must agree.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
import torch as th
from gymnasium import spaces
from stable_baselines3.common.preprocessing import preprocess_obs

from drx.settings.hyperparameters import Hyperparameters
from drx.train import networks
from drx.train.algorithms import build_algorithm
from drx.train.buffer import EpisodeDictRolloutBuffer, EpisodeRolloutBuffer
from drx.train.ppo import EpisodicPPO
from drx.vehicle import Vehicle, default_vehicle

from .dummy_env import CorridorEnv

STEPS = 64  # one minibatch of 64, or two of 32


def _model(network: str, towers: str, fast: bool, continuous: bool, lidar: bool) -> EpisodicPPO:
    """A PPO model whose buffer holds the same random steps (seeded) whatever ``fast`` is."""
    if continuous:
        car = Vehicle(name="c", continuous=True, speed_range=(0.5, 1.0), network=network, lidar=lidar)
    else:
        car = Vehicle(name="d", actions=default_vehicle().actions, network=network, lidar=lidar)
    model = build_algorithm(CorridorEnv(car, lidar=lidar), network, Hyperparameters(towers=towers), seed=0)
    assert isinstance(model, EpisodicPPO)
    model.fast_update = fast
    rng = np.random.default_rng(1)
    model.rollout_buffer.reset()
    for i in range(STEPS):
        frame = rng.integers(0, 256, (1, 1, 120, 160), dtype=np.uint8)
        obs: Any = (
            {"camera": frame, "lidar": rng.uniform(0, 2, (1, 8)).astype(np.float32)} if lidar else frame
        )
        action = rng.uniform(-1, 1, 2).astype(np.float32) if continuous else np.array(rng.integers(0, 10))
        model._add_step(
            obs, action, float(rng.normal()), i % 20 == 0, float(rng.normal()), float(rng.normal() - 2)
        )
    model._close_buffer(STEPS, STEPS, 4, 4)
    return model


def _update(model: EpisodicPPO, epochs: int, batch_size: int) -> dict[str, th.Tensor]:
    """Run one update; the policy's parameters after it."""
    model.n_epochs, model.batch_size = epochs, batch_size
    np.random.seed(0)  # the buffer's minibatch permutation
    model.train()
    return {name: p.detach().clone() for name, p in model.policy.named_parameters()}


CASES = [
    ("shallow", "shared", False, False),
    ("shallow", "separate", True, False),
    ("shallow", "shared", False, True),
    ("deep", "shared", False, False),
    ("compact", "separate", False, False),
]


@pytest.mark.parametrize(("network", "towers", "continuous", "lidar"), CASES)
def test_fast_update_matches_sb3s(
    network: str, towers: str, continuous: bool, lidar: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    fast_calls = []
    plain_forward = networks.CameraCNN._forward_fast

    def counting(self: networks.CameraCNN, *args: Any) -> th.Tensor:
        fast_calls.append(self.kind)
        return plain_forward(self, *args)

    monkeypatch.setattr(networks.CameraCNN, "_forward_fast", counting)
    sb3, fast = (_model(network, towers, f, continuous, lidar) for f in (False, True))
    start = {name: p.detach().clone() for name, p in sb3.policy.named_parameters()}

    # One minibatch of everything: the gradients (left on the parameters by train()) agree.
    _update(sb3, epochs=1, batch_size=STEPS)
    assert not fast_calls
    _update(fast, epochs=1, batch_size=STEPS)
    assert bool(fast_calls) == (network in networks.FAST_KINDS)
    for (name, a), b in zip(sb3.policy.named_parameters(), fast.policy.parameters(), strict=True):
        assert a.grad is not None and b.grad is not None, name
        scale = float(a.grad.abs().max())
        th.testing.assert_close(
            b.grad, a.grad, rtol=1e-4, atol=1e-5 * scale, msg=lambda m, n=name: f"{n}: {m}"
        )

    # Then an epoch of two minibatches: the parameters still agree, to 5% of how far the
    # update moved them. Adam's step is about the learning rate whatever the gradient's size, so a
    # rounding difference in a near-zero gradient (or a unit whose input sits at ReLU's kink)
    # moves a weight by a fraction of a step: deep's worst weight differed by 1.4% of it.
    after_sb3, after_fast = (_update(m, epochs=1, batch_size=STEPS // 2) for m in (sb3, fast))
    moved = max(float((after_sb3[n] - start[n]).abs().max()) for n in start)
    assert moved > 1e-4
    for name, a in after_sb3.items():
        th.testing.assert_close(
            after_fast[name], a, rtol=1e-4, atol=0.05 * moved, msg=lambda m, n=name: f"{n}: {m}"
        )
    for key in ("train/loss", "train/value_loss", "train/approx_kl"):
        assert fast.logger.name_to_value[key] == pytest.approx(
            sb3.logger.name_to_value[key], rel=1e-3, abs=1e-6
        )


FRAME = spaces.Box(0, 255, (1, 120, 160), np.uint8)
DICT = spaces.Dict({"camera": FRAME, "lidar": spaces.Box(0.0, 2.0, (8,), np.float32)})


@pytest.mark.parametrize(("space", "pool"), [(FRAME, 1), (FRAME, 4), (DICT, 1)])
def test_divided_frames_are_sb3s(space: spaces.Space, pool: int) -> None:
    """Minibatches of a buffer handing out divided frames are SB3's, preprocessed, to the bit."""

    def filled() -> EpisodeRolloutBuffer | EpisodeDictRolloutBuffer:
        rng = np.random.default_rng(2)
        buffer_class = EpisodeDictRolloutBuffer if isinstance(space, spaces.Dict) else EpisodeRolloutBuffer
        buf = buffer_class(4, space, spaces.Discrete(3), device="cpu", pool=pool)
        for t in range(10):
            frame = rng.integers(0, 256, (1, 1, 120, 160), dtype=np.uint8)
            obs: Any = {"camera": frame, "lidar": rng.uniform(0, 2, (1, 8)).astype(np.float32)}
            buf.add(obs if isinstance(space, spaces.Dict) else frame, np.array([[t % 3]]), np.array([1.0]),
                    np.array([t == 0]), th.zeros(1), th.zeros(1))  # fmt: skip
        buf.finish(th.zeros(1), np.array([True]))
        return buf

    sb3, ours = filled(), filled()
    keys = ["camera"] if isinstance(space, spaces.Dict) else [""]
    with ours.divided_frames(255.0, keys):
        for _ in range(2):  # two epochs, as an update reads the buffer
            np.random.seed(3)
            divided = list(ours.get(4))
            np.random.seed(3)
            for a, b in zip(sb3.get(4), divided, strict=True):
                expected = preprocess_obs(a.observations, space)
                if isinstance(expected, dict):
                    assert all(th.equal(b.observations[k], expected[k]) for k in expected)
                else:
                    assert th.equal(b.observations, expected)
                assert th.equal(a.actions, b.actions) and th.equal(a.advantages, b.advantages)
    # Outside the context the buffer hands out what SB3's does (its stored frames were not changed).
    np.random.seed(4)
    after = list(ours.get(4))
    np.random.seed(4)
    for a, b in zip(sb3.get(4), after, strict=True):
        assert type(a.observations) is type(b.observations)
        if isinstance(a.observations, dict):
            assert all(th.equal(a.observations[k], b.observations[k]) for k in a.observations)
        else:
            assert th.equal(a.observations, b.observations)


@pytest.mark.parametrize("kind", ["shallow", "deep"])
def test_fast_forward_matches_and_the_check_can_fail(kind: str) -> None:
    """A gradient step's forward (the fast path) gives the plain forward's features; the same check
    catches a fast path that computes something else (here a dense bias off by 1e-3)."""
    net = networks.CameraCNN(FRAME, kind)
    frames = th.rand(8, 1, 120, 160)
    with th.no_grad():
        plain = net(frames)
    fast = net(frames)
    assert fast.grad_fn is not None and plain.grad_fn is None
    th.testing.assert_close(fast.detach(), plain, rtol=1e-4, atol=1e-5)
    with th.no_grad():
        net.head[-2].bias.add_(1e-3)
    with pytest.raises(AssertionError):
        th.testing.assert_close(net(frames).detach(), plain, rtol=1e-4, atol=1e-5)
