"""Distilling a drx policy into DeepRacer's ``shallow`` network (drx.interchange.deepracer.distill).

The fast tests distil an untrained ``compact`` policy whose action head is sharpened and centred
(its weights scaled up and its bias set against its mean output, so that what it does depends on
the frame, as a trained policy's does) on the small ``oval``, for a few seconds. The slow test
trains a real model on reinvent_base and checks that the student laps as the teacher does.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest
import torch as th
from stable_baselines3.common.policies import ActorCriticPolicy, BasePolicy

from drx.interchange.deepracer import distill
from drx.interchange.deepracer.distill import ACTION_TOLERANCE, DistillReport, distill_policy
from drx.registry.testing import fresh_registry
from drx.sim.env import DeepRacerEnv
from drx.train.policy_weights import build_policy
from drx.vehicle import Vehicle, default_vehicle

SECONDS = 10.0  # each fast distillation's budget
# The untrained action head's weights times this: discrete logits of a few units (several actions are
# chosen on the oval), continuous means spread by ~0.1 round the middle of the box.
SHARPEN = {False: 300.0, True: 100.0}
CONTINUOUS = Vehicle(name="cont", continuous=True, steering_range=(-30.0, 30.0), speed_range=(0.5, 2.0))
TEACHER_LOG_STD = -0.7  # not the initial 0, so that the copy shows


@pytest.fixture(autouse=True)
def _fresh_registry(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    yield from fresh_registry(monkeypatch)


@pytest.fixture
def short_episodes(monkeypatch: pytest.MonkeyPatch) -> None:
    """Episodes of at most 80 steps: the first round then collects ~1000 frames in a second or two,
    leaving the fast tests' few seconds to training even on a busy machine."""
    monkeypatch.setattr(distill, "MAX_EPISODE_STEPS", 80)


@pytest.fixture(autouse=True)
def _one_thread() -> Iterator[None]:
    """The tests' own forward passes on one thread: torch loads here before ``drx.train`` can make
    OpenMP's threads wait passively, and spinning threads are several times slower on a busy machine."""
    threads = th.get_num_threads()
    th.set_num_threads(1)
    yield
    th.set_num_threads(threads)


def sharp_teacher(vehicle: Vehicle, seed: int = 7) -> ActorCriticPolicy:
    """An untrained ``compact`` policy whose action depends clearly on the frame."""
    with th.random.fork_rng(devices=[]):
        th.manual_seed(seed)
        teacher = build_policy(vehicle, "ppo")
    assert isinstance(teacher, ActorCriticPolicy)
    with th.no_grad():
        teacher.action_net.weight.mul_(SHARPEN[vehicle.continuous])  # type: ignore[operator]
        if vehicle.continuous:
            teacher.log_std.fill_(TEACHER_LOG_STD)
        frames = th.as_tensor(frames_driven_by(teacher, vehicle, steps=200))
        head: Any = teacher.action_net
        head.bias.sub_(head(teacher.extract_features(frames)).mean(0))
    teacher.set_training_mode(False)
    return teacher


def oval_env(vehicle: Vehicle) -> Callable[[], DeepRacerEnv]:
    """The env factory distillation drives: the oval, in evaluation mode."""
    return lambda: DeepRacerEnv(track="oval", vehicle=vehicle, mode="evaluation")


def frames_driven_by(teacher: BasePolicy, vehicle: Vehicle, steps: int = 40) -> np.ndarray:
    """Frames (channel-first, batched) the teacher sees driving from four starts, none used in training."""
    env = oval_env(vehicle)()
    frames = []
    for k, start in enumerate((0.1, 0.35, 0.6, 0.85)):
        obs, _ = env.reset(seed=1000 + k, options={"start": start})
        for _ in range(steps):
            frames.append(obs)
            action, _ = teacher.predict(obs, deterministic=True)
            obs, _, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                break
    return np.stack(frames).transpose(0, 3, 1, 2)  # (N, H, W, C) -> (N, C, H, W), as the policy reads


def actions(policy: BasePolicy, frames: np.ndarray) -> th.Tensor:
    """Discrete: the action probabilities; continuous: the Gaussian's mean in the box."""
    assert isinstance(policy, ActorCriticPolicy)
    with th.no_grad():
        dist: Any = policy.get_distribution(th.as_tensor(frames)).distribution
    if isinstance(dist, th.distributions.Categorical):
        return dist.probs
    return dist.mean.clamp(-1.0, 1.0)


def agreement(
    student: BasePolicy, teacher: BasePolicy, frames: np.ndarray, discrete: bool
) -> tuple[float, float]:
    """The report's agreement and action error, measured independently on ``frames``."""
    s, t = actions(student, frames), actions(teacher, frames)
    if discrete:
        return float((s.argmax(1) == t.argmax(1)).float().mean()), float(0.5 * (s - t).abs().sum(1).mean())
    return float(((s - t).abs() <= ACTION_TOLERANCE).all(1).float().mean()), float((s - t).abs().mean())


def untrained_student(vehicle: Vehicle, seed: int) -> BasePolicy:
    """The student as distillation starts it (the same seed gives the same initial weights)."""
    with th.random.fork_rng(devices=[]):
        th.manual_seed(seed)
        return build_policy(dataclasses.replace(vehicle, network="shallow"), "ppo")


def check_report(report: DistillReport, max_seconds: float) -> None:
    """The report's fields are in range and agree with each other."""
    assert 0.0 <= report.agreement <= 1.0
    assert report.mean_action_error >= 0.0
    assert report.value_r2 <= 1.0
    assert report.rounds >= 1 and report.frames > 0
    assert 0.0 < report.seconds <= max_seconds + 15.0  # a minibatch, a scoring pass and closing the env
    assert DistillReport(**report.to_dict()) == report  # type: ignore[arg-type]
    assert set(report.to_dict()) == {f.name for f in dataclasses.fields(DistillReport)}


@pytest.mark.parametrize("vehicle", [default_vehicle(), CONTINUOUS], ids=["discrete", "continuous"])
@pytest.mark.usefixtures("short_episodes")
def test_distilled_student_is_shallow_and_closer_to_the_teacher(vehicle: Vehicle) -> None:
    teacher = sharp_teacher(vehicle)
    discrete = not vehicle.continuous
    frames = frames_driven_by(teacher, vehicle)
    if discrete:  # the teacher must not be trivial: more than one action is its choice on these frames
        assert len(set(actions(teacher, frames).argmax(1).tolist())) > 1
    before = agreement(untrained_student(vehicle, seed=3), teacher, frames, discrete)
    rng_state, threads = th.random.get_rng_state(), th.get_num_threads()
    messages: list[str] = []

    student, report = distill_policy(
        teacher, vehicle, oval_env(vehicle), seed=3, max_seconds=SECONDS, on_progress=messages.append
    )

    assert isinstance(student, ActorCriticPolicy)
    assert getattr(student.features_extractor, "kind", None) == "shallow"
    assert not student.training
    assert student.action_space == teacher.action_space
    assert student.observation_space == teacher.observation_space
    if vehicle.continuous:
        assert th.equal(student.log_std, teacher.log_std)
        assert th.allclose(student.log_std, th.full((2,), TEACHER_LOG_STD))
    after = agreement(student, teacher, frames, discrete)
    # a few seconds of training (fewer minibatches on a busy machine) already beat the untrained student
    assert after[0] > before[0] + (0.25 if discrete else 0.1), (before, after, report)
    assert after[1] < before[1], (before, after, report)
    assert report.agreement > 0.25, report  # the untrained discrete student agrees on ~2% of the frames
    check_report(report, SECONDS)
    assert messages and messages[0].startswith("round 1")
    # nothing global changed: torch's random state and thread count are as they were
    assert th.equal(th.random.get_rng_state(), rng_state)
    assert th.get_num_threads() == threads


def test_the_seed_fixes_the_student_and_the_teacher_is_left_alone() -> None:
    vehicle = default_vehicle()
    teacher = sharp_teacher(vehicle)
    weights = {k: v.clone() for k, v in teacher.state_dict().items()}
    first, _ = distill_policy(teacher, vehicle, oval_env(vehicle), seed=5, max_seconds=0.0)
    again, report = distill_policy(teacher, vehicle, oval_env(vehicle), seed=5, max_seconds=0.0)
    pairs = zip(first.state_dict().values(), again.state_dict().values(), strict=True)
    assert all(th.equal(a, b) for a, b in pairs)
    other: Any = untrained_student(vehicle, seed=6)
    assert not th.equal(first.state_dict()["action_net.weight"], other.state_dict()["action_net.weight"])
    assert all(th.equal(weights[k], v) for k, v in teacher.state_dict().items())
    assert (report.rounds, report.frames) == (0, 0)  # no time: nothing collected, nothing trained


def test_a_sac_policy_is_refused() -> None:
    from drx.errors import DrxError

    sac = build_policy(CONTINUOUS, "sac")
    with pytest.raises(DrxError, match="Only PPO policies"):
        distill_policy(sac, CONTINUOUS, oval_env(CONTINUOUS), max_seconds=1.0)


# ----- slow: a trained model, raced ---------------------------------------------------------------------


def _train(name: str, minutes: float) -> Any:
    """Create ``name`` on reinvent_base with every default and train it (as ``drx train`` does)."""
    from drx.queue.dispatch import run_job
    from drx.queue.lifecycle import enqueue_training
    from drx.services import models as model_service

    model_service.create_model(name, track="reinvent_base", stop_conditions={"max_minutes": minutes})
    outcome = run_job(enqueue_training(name, {"seed": 0}).id)
    assert outcome.status == "succeeded", outcome
    return outcome


@pytest.mark.slow
def test_a_distilled_model_laps_as_the_original() -> None:
    from drx.evaluate import service
    from drx.evaluate.time_trial import run_time_trial
    from drx.train.policy_weights import load_policy_weights

    _train("m1", minutes=2.0)
    prepared = service.prepare(service.EvaluationRequest(model="m1", laps=3, seed=0))
    teacher = load_policy_weights(prepared.checkpoint.path, prepared.vehicle, "ppo")
    student, report = distill_policy(teacher, prepared.vehicle, lambda: service.make_env(prepared), seed=0)

    def race(policy: BasePolicy) -> Any:
        env = service.make_env(prepared)
        try:
            return run_time_trial(
                env, lambda obs: policy.predict(obs, deterministic=True)[0], prepared.rules, seed=0
            )
        finally:
            env.close()

    original, distilled = race(teacher), race(student)
    assert original.laps_completed == 3, "the teacher does not lap; train it longer"
    assert distilled.laps_completed == 3, (report, distilled)
    assert distilled.fastest_lap <= 1.1 * original.fastest_lap, (report, original, distilled)
    assert report.agreement >= 0.8, report
