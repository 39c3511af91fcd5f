"""drx's SAC update: one camera encoder, trained by the critic's loss, read by the actor detached."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import torch as th

from drx.settings.hyperparameters import Hyperparameters
from drx.train import algorithms
from drx.train.checkpoint import read_meta, save_checkpoint
from drx.train.sac import EpisodicSAC
from drx.train.trainer import Trainer

from .conftest import SpecFactory, compact_car
from .dummy_env import CorridorEnv

PURSUIT_LIKE = 80.0  # [per step] what the pursuit reward pays a car at race pace


def _pays(amount: float) -> Any:
    """A reward function paying ``amount`` a step on the road, as the pursuit reward pays tens."""
    return lambda params: amount if params["all_wheels_on_track"] else 0.01


def _model(reward: Any = None, scale_rewards: bool = True) -> EpisodicSAC:
    env = CorridorEnv(vehicle=compact_car(continuous=True), reward_function=reward)
    model = algorithms.build_algorithm(env, "compact", Hyperparameters.default("sac"), seed=0)
    assert isinstance(model, EpisodicSAC)
    model.scale_rewards = scale_rewards
    model.collect_episodes(2)
    return model


def _weights(module: th.nn.Module) -> list[np.ndarray]:
    return [p.detach().numpy().copy() for p in module.parameters()]


def _moved(before: list[np.ndarray], after: list[np.ndarray]) -> bool:
    return any(not np.allclose(a, b) for a, b in zip(before, after, strict=True))


def test_the_encoder_takes_one_backward_pass_per_gradient_step_from_the_critic_only() -> None:
    """SB3's SAC runs backward through the critic's encoder twice a step (its loss and the
    actor's) and once through the actor's; drx's runs it once, for the critic's loss."""
    model = _model()
    critic_encoder = model.critic.features_extractor
    actor_encoder = model.actor.features_extractor
    backward = {"critic": 0, "actor": 0}
    first_critic = next(critic_encoder.parameters())
    first_actor = next(actor_encoder.parameters())
    first_critic.register_hook(lambda g: backward.__setitem__("critic", backward["critic"] + 1))
    first_actor.register_hook(lambda g: backward.__setitem__("actor", backward["actor"] + 1))
    model.train(gradient_steps=3, batch_size=8)
    assert backward == {"critic": 3, "actor": 0}
    assert all(p.grad is None for p in model.critic_target.features_extractor.parameters())


def test_the_target_encoder_runs_once_a_step_and_follows_by_polyak_averaging() -> None:
    """The critic's encoder runs forward twice a gradient step (the batch, and the next frames for the
    actor's next action), the target's once (the next frames for the target critics); the target,
    encoder and heads, moves a tau at a time towards the critic, never by a gradient of its own."""
    model = _model()
    calls = {"critic": 0, "target": 0}
    model.critic.features_extractor.register_forward_hook(
        lambda *_: calls.__setitem__("critic", calls["critic"] + 1)
    )
    model.critic_target.features_extractor.register_forward_hook(
        lambda *_: calls.__setitem__("target", calls["target"] + 1)
    )
    before = _weights(model.critic_target)
    model.train(gradient_steps=3, batch_size=8)
    assert calls == {"critic": 6, "target": 3}
    after = _weights(model.critic_target)
    assert _moved(before, after)
    assert all(p.grad is None for p in model.critic_target.parameters())
    step = max(float(np.abs(a - b).max()) for a, b in zip(after, before, strict=True))
    span = max(float(np.abs(o - b).max()) for o, b in zip(_weights(model.critic), before, strict=True))
    assert step < 3 * model.tau * span + 1e-7


def test_the_actors_loss_leaves_no_gradient_on_the_critics_heads() -> None:
    """The actor's loss runs back through the critics' heads to the actions only: their own
    gradients, which SB3 computes and the next critic step throws away, are not computed, and the
    heads train again afterwards."""
    model = _model()
    model.train(gradient_steps=1, batch_size=8)
    features = th.rand(8, model.critic.features_extractor.features_dim)
    model.critic.optimizer.zero_grad(set_to_none=True)
    model._actor_step(features)
    heads = [p for q in model.critic.q_networks for p in q.parameters()]
    assert all(p.grad is None and p.requires_grad for p in heads)
    assert any(p.grad is not None for p in model.actor.mu.parameters())


def test_the_actor_reads_the_critics_encoder_after_an_update() -> None:
    model = _model()
    before_encoder = _weights(model.critic.features_extractor)
    before_actor_head = _weights(model.actor.mu)
    before_q = _weights(model.critic.q_networks[0])
    model.train(gradient_steps=4, batch_size=8)
    trained = _weights(model.critic.features_extractor)
    assert _moved(before_encoder, trained)
    for mine, theirs in zip(_weights(model.actor.features_extractor), trained, strict=True):
        np.testing.assert_array_equal(mine, theirs)
    assert _moved(before_actor_head, _weights(model.actor.mu))
    assert _moved(before_q, _weights(model.critic.q_networks[0]))
    assert model.logger.name_to_value["train/std"] > 0.0


def test_a_cut_update_still_hands_the_actor_the_trained_encoder() -> None:
    model = _model()
    calls = iter([True, True, False])
    model.train(gradient_steps=5, batch_size=8, on_batch=lambda _e, _n: next(calls))
    assert model.update_cut
    for mine, theirs in zip(
        _weights(model.actor.features_extractor), _weights(model.critic.features_extractor), strict=True
    ):
        np.testing.assert_array_equal(mine, theirs)


def test_rewards_reach_the_critics_in_units_of_their_running_rms() -> None:
    """A reward of tens a step reaches SAC's critics as about 1 a step, so ``sac_alpha`` weighs
    entropy against what DeepRacer's usual rewards pay (unscaled, the pursuit reward's SAC never
    lapped A to Z Speedway in 10 minutes; see drx.train.sac)."""
    model = _model(_pays(PURSUIT_LIKE))
    n = model.replay_buffer.pos  # type: ignore[union-attr]
    model.train(gradient_steps=n, batch_size=8)
    rewards = model.replay_buffer.rewards[:n, 0]  # type: ignore[union-attr]
    assert model.reward_scale.rms == pytest.approx(float(np.sqrt(np.mean(rewards**2))))
    assert model.logger.name_to_value["train/reward_scale"] == pytest.approx(model.reward_scale.rms)
    scaled_loss = model.logger.name_to_value["train/critic_loss"]
    raw = _model(_pays(PURSUIT_LIKE), scale_rewards=False)
    raw.train(gradient_steps=n, batch_size=8)
    # The same first targets, 80 times larger: the critic's squared error is thousands of times larger.
    assert raw.logger.name_to_value["train/critic_loss"] > 100 * scaled_loss


def test_an_update_records_the_spread_and_the_share_on_a_bound() -> None:
    model = _model()
    model.train(gradient_steps=3, batch_size=8)
    figures = algorithms.update_metrics(model)[1]
    assert set(figures) == {"std", "at_bound_steering", "at_bound_speed", "reward_scale"}
    assert figures["std"] > 0.0 and 0.0 <= figures["at_bound_steering"] <= 1.0


def test_a_resumed_or_cloned_run_keeps_the_reward_scale(corridor_spec: SpecFactory, tmp_path: Path) -> None:
    car = compact_car(continuous=True)

    def sac(folder: str) -> Any:
        return corridor_spec(folder=tmp_path / folder, car=car, algorithm="sac", episodes_per_iteration=2)

    trainer = Trainer(sac("a"))
    trainer.run()
    assert isinstance(trainer.model, EpisodicSAC)
    saved = read_meta(tmp_path / "a" / "model" / "last.zip")["reward_scale"]["rms"]
    assert saved == pytest.approx(trainer.model.reward_scale.rms) and saved > 0
    resumed = Trainer(sac("a"))
    clone = Trainer(replace(sac("b"), init_checkpoint=tmp_path / "a" / "model" / "last.zip"))
    for other in (resumed, clone):
        assert isinstance(other.model, EpisodicSAC)
        assert other.model.reward_scale.rms == pytest.approx(saved)
        other.close()


def test_the_newest_rewards_are_read_across_the_replay_buffers_wrap() -> None:
    model = _model()
    buffer = model.replay_buffer
    assert buffer is not None
    buffer.rewards[:, 0] = np.arange(buffer.buffer_size)
    buffer.pos, buffer.full = 2, True  # the buffer wrapped: the newest are at 1, 0, then the end
    size = buffer.buffer_size
    assert model._newest_rewards(5).tolist() == [1, 0, size - 1, size - 2, size - 3]
    buffer.full = False
    assert model._newest_rewards(5).tolist() == [1, 0]  # never more than were stored


def test_a_checkpoint_from_before_the_shared_encoder_keeps_driving_as_it_did(
    corridor_spec: SpecFactory, tmp_path: Path
) -> None:
    """An older SAC checkpoint (no reward scale in its drx.json) has two encoders; its actor head
    was trained on the actor's, which the critics adopt, so the clone's policy drives unchanged."""
    old = _model()
    with th.no_grad():
        for param in old.actor.features_extractor.parameters():
            param.add_(0.05)  # an actor encoder of its own, unlike the critic's
    frame = th.as_tensor(np.random.default_rng(1).integers(0, 256, (1, 1, 120, 160)), dtype=th.float32)
    with th.no_grad():
        before = old.actor(frame, deterministic=True).numpy()
    save_checkpoint(old, tmp_path / "old.zip", {"algorithm": "sac", "network": "compact"})
    car = compact_car(continuous=True)
    spec = corridor_spec(folder=tmp_path / "clone", car=car, algorithm="sac", episodes_per_iteration=2)
    clone = Trainer(replace(spec, init_checkpoint=tmp_path / "old.zip"))
    model = clone.model
    assert isinstance(model, EpisodicSAC)
    actor_encoder = _weights(model.actor.features_extractor)
    for encoder in (model.critic.features_extractor, model.critic_target.features_extractor):
        for mine, theirs in zip(_weights(encoder), actor_encoder, strict=True):
            np.testing.assert_array_equal(mine, theirs)
    with th.no_grad():
        after = model.actor(frame, deterministic=True).numpy()
    np.testing.assert_allclose(after, before, atol=1e-6)
    assert model.reward_scale.rms is None  # it starts anew from the clone's first iteration
    clone.close()
