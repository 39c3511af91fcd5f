"""drx's choices that keep PPO stable (drx/train/stability.py), unit by unit and inside an update."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import torch as th

from drx.settings.hyperparameters import Hyperparameters
from drx.train import algorithms
from drx.train.checkpoint import read_meta
from drx.train.ppo import EpisodicPPO, at_bound_shares
from drx.train.stability import (
    MAX_LOG_STD,
    ReturnScale,
    bound_loss,
    cap_log_std,
    discounted_returns,
)
from drx.train.trainer import Trainer

from .conftest import SpecFactory, compact_car
from .dummy_env import CorridorEnv


def test_discounted_returns_restart_at_every_episode() -> None:
    rewards = np.array([1.0, 1.0, 1.0, 5.0, 5.0])
    starts = np.array([True, False, False, True, False])
    got = discounted_returns(rewards, starts, 0.5)
    assert got == pytest.approx([1.75, 1.5, 1.0, 7.5, 5.0])


def test_return_scale_is_the_returns_rms_and_follows_a_faster_car() -> None:
    scale = ReturnScale(momentum=0.9)
    first = scale.update(np.array([3.0, 4.0]))  # rms of the first iteration itself
    assert first == pytest.approx(math.sqrt(12.5))
    later = scale.update(np.array([30.0, 40.0]))  # a tenth of the new iteration's square comes in
    assert later == pytest.approx(math.sqrt(0.9 * 12.5 + 0.1 * 1250.0))
    rewards = np.array([100.0, 100.0, 100.0])
    scaled = ReturnScale().scale_rewards(rewards, np.array([True, False, False]), 0.995)
    returns = discounted_returns(scaled, np.array([True, False, False]), 0.995)
    assert np.sqrt(np.mean(returns**2)) == pytest.approx(1.0)  # value targets near 1, whatever the reward


def test_return_scale_state_round_trips_and_ignores_nonsense() -> None:
    scale = ReturnScale()
    scale.update(np.array([10.0]))
    restored = ReturnScale()
    restored.restore(scale.state())
    assert restored.rms == scale.rms == pytest.approx(10.0)
    for bad in (None, {}, {"rms": None}, {"rms": -1.0}, {"rms": float("nan")}):
        restored.restore(bad)
        assert restored.rms is None


def test_bound_loss_is_zero_inside_the_box_and_grows_past_it() -> None:
    assert float(bound_loss(th.tensor([[0.99, -1.0], [0.0, 0.5]]))) == 0.0
    assert float(bound_loss(th.tensor([[2.0, 0.0]]))) == pytest.approx(1.0)
    assert float(bound_loss(th.tensor([[-3.0, 1.5]]))) == pytest.approx(4.25)


def test_cap_log_std_clamps_in_place() -> None:
    log_std = th.nn.Parameter(th.tensor([2.5, -0.5]))
    cap_log_std(log_std)
    assert log_std.tolist() == pytest.approx([MAX_LOG_STD, -0.5])


def test_at_bound_shares_count_each_dimension() -> None:
    actions = np.array([[[1.0, 0.2]], [[-1.4, 0.9]], [[0.3, 1.2]], [[0.0, 0.0]]])
    assert at_bound_shares(actions) == pytest.approx([0.5, 0.25])


def _continuous_ppo(**hp: object) -> EpisodicPPO:
    env = CorridorEnv(vehicle=compact_car(continuous=True))
    model = algorithms.build_algorithm(env, "compact", Hyperparameters(**hp), seed=0)  # type: ignore[arg-type]
    assert isinstance(model, EpisodicPPO)
    return model


def _excess(model: EpisodicPPO) -> float:
    """The mean amount by which the policy's action means lie past +-1 on the buffer's observations."""
    data = next(iter(model.rollout_buffer.get(None)))  # the whole buffer, as the update reads it
    with th.no_grad():
        mean = model._evaluate_actions(data.observations, data.actions)[3]
    assert mean is not None
    return float((mean.abs() - 1.0).clamp(min=0.0).mean())


def _update_with_nothing_to_learn(model: EpisodicPPO) -> tuple[float, float]:
    """Put both action means far past their bounds, collect, zero the advantages (only the entropy
    bonus and the bound's pull are left), update; the mean excess past the box before and after."""
    with th.no_grad():
        model.policy.action_net.bias.copy_(th.tensor([3.0, -3.0]))
    collected = model.collect_episodes_driven(model.get_env().envs[0], 5, 0, seed=0)  # type: ignore[union-attr]
    assert collected.buffered_steps > 0
    model.rollout_buffer.advantages[:] = 0.0
    before = _excess(model)
    model.train()
    return before, _excess(model)


def test_an_update_keeps_the_spread_and_the_mean_inside_the_box(monkeypatch: pytest.MonkeyPatch) -> None:
    """The mechanism of the issue's collapse: an entropy bonus with nothing to learn widens the
    Gaussian, and a mean past a bound drifts there unchecked. Neither survives an update."""
    model = _continuous_ppo(entropy=1.0, episodes_per_iteration=5)
    before, after = _update_with_nothing_to_learn(model)
    assert float(model.policy.log_std.detach().max()) <= MAX_LOG_STD
    assert after < before - 0.03  # pulled back toward the box
    _, figures = algorithms.update_metrics(model)
    for name in ("clip_fraction", "explained_variance", "std", "at_bound_steering", "at_bound_speed"):
        assert figures[name] is not None
    assert figures["at_bound_steering"] > 0.9  # the samples did pile on a bound: it is measured
    monkeypatch.setattr("drx.train.ppo.BOUND_LOSS_COEF", 0.0)
    unguarded = _continuous_ppo(entropy=1.0, episodes_per_iteration=5)
    before, after = _update_with_nothing_to_learn(unguarded)
    assert after > before - 0.01  # without the pull nothing brings it back


def test_rewards_reach_the_value_head_in_units_of_the_return_scale() -> None:
    model = _continuous_ppo(episodes_per_iteration=5)
    env = model.get_env().envs[0]  # type: ignore[union-attr]
    model.collect_episodes_driven(env, 5, 0, seed=0)
    buffer = model.rollout_buffer
    n = buffer.pos
    returns = discounted_returns(buffer.rewards[:n, 0], buffer.episode_starts[:n, 0], model.gamma)
    assert np.sqrt(np.mean(returns**2)) == pytest.approx(1.0, rel=1e-6)
    assert model.bootstrap_factor == pytest.approx(model.gamma * model.return_scale.rms)


def test_a_resumed_or_cloned_run_keeps_the_return_scale(corridor_spec: SpecFactory, tmp_path: Path) -> None:
    spec = corridor_spec(folder=tmp_path / "a", car=compact_car(continuous=True))
    trainer = Trainer(spec)
    trainer.run()
    assert isinstance(trainer.model, EpisodicPPO)
    saved = read_meta(tmp_path / "a" / "model" / "last.zip")["return_scale"]["rms"]
    assert saved == pytest.approx(trainer.model.return_scale.rms)
    car = compact_car(continuous=True)
    resumed = Trainer(corridor_spec(folder=tmp_path / "a", car=car))
    clone_spec = corridor_spec(folder=tmp_path / "b", car=car)
    clone = Trainer(replace(clone_spec, init_checkpoint=tmp_path / "a" / "model" / "last.zip"))
    for other in (resumed, clone):
        assert isinstance(other.model, EpisodicPPO)
        assert other.model.return_scale.rms == pytest.approx(saved)
        other.close()
