"""A drx policy taught into DeepRacer's ``shallow`` network (policy distillation with DAgger).

DeepRacer's model folder holds DeepRacer's own networks only, so a model trained on drx's
``compact`` CNN cannot be exported as it is: its behaviour has to be copied into a ``shallow``
network first. :func:`distill_policy` does that by supervised learning on camera frames of the
model's own track: the trained policy (the *teacher*) labels every frame with what it would do
(its action probabilities, or its Gaussian's mean) and what it expects (its value), and a fresh
``shallow`` PPO policy (the *student*, same action and observation spaces) learns to output the
same, heads and all, until it drives as the teacher does.

**Which frames.** Behaviour cloning alone, learning on the teacher's own laps, drifts: the
student's small errors take it to states the teacher never visited, where its errors grow, and
they compound over a lap (Ross, Gordon and Bagnell, "A Reduction of Imitation Learning and
Structured Prediction to No-Regret Online Learning", AISTATS 2011: the error of cloning grows
with the square of the horizon, DAgger's linearly). So frames are collected in rounds (DAgger):

1. round 1, the teacher drives: its most probable action from the start line (the states an
   evaluation visits), from starts spread round the lap, and with its sampled actions (as in
   training), which take the car off the ideal line and show the teacher's corrections;
2. later rounds, the student drives (its most probable action, from the start line and from
   spread starts), and the teacher labels every frame it sees: the student learns what to do in
   the states its own mistakes lead to.

After each round the student trains on everything collected so far (the aggregate, as DAgger
prescribes). The held-out figures come from whole episodes kept out of training (every
:data:`HELD_OUT_EVERY`-th): neighbouring frames of one episode are near copies, so frames held out
at random would flatter the student.

**Losses.** Discrete cars: the cross-entropy of the student's logits against the teacher's
probabilities (the KL divergence up to the teacher's entropy, a constant), so the student learns
the whole distribution, not just its top action. Continuous cars: the squared error of the
Gaussians' means in the normalised box [-1, 1] (the teacher's mean clipped to the box: a mean past
a bound drives as the bound does), and the teacher's state-independent ``log_std`` is copied. The
value head learns the teacher's value (same units) by squared error, divided by the variance of
the teacher's values so that its weight does not depend on the reward's scale; it starts at the
teacher's mean value. Adam, minibatches of :data:`BATCH_SIZE`, torch on one thread (:func:`_threads`).

**What it achieves** (2-core machine shared with other jobs, load 3-10, 300 s, 3-lap races with
three seeds): the default car on reinvent_base (10 actions) distilled from a 3-minute model's best
checkpoint agreed on 0.96 of the held-out frames and lapped 3/3 at 0.997-1.014x the teacher's
fastest lap; from its last checkpoint 0.90, 3/3, 0.99-1.016x; a continuous car on A to Z
Speedway (6 minutes of training, 9.2 s laps) agreed on 0.64 within 0.1 of the box (mean error
0.06) and lapped 3/3 at 0.96-1.03x.

**Budget and repeatability.** ``max_seconds`` covers collection and training; a last round is not
started when it could not be trained on in the time left (the time trains on the frames there are
instead). Frames are kept as uint8 (19 kB each; 300 s collects 10 000-15 000). With the same seed
the same student comes out as long as the run stops at the same point: a run cut by its time
budget stops wherever the machine's speed has got it.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import gymnasium as gym
import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3.common.policies import ActorCriticPolicy, BasePolicy
from torch.nn import functional as F

from drx.errors import DrxError
from drx.train.networks import useful_threads
from drx.train.policy_weights import build_policy
from drx.vehicle import Vehicle

STUDENT_NETWORK = "shallow"  # DeepRacer's 3-layer CNN, the network its model folder holds
ACTION_TOLERANCE = 0.1  # [box units] continuous: a student mean this close to the teacher's agrees
HELD_OUT_EVERY = 5  # every 5th episode is kept out of training, to measure the student
BATCH_SIZE = 32  # frames per minibatch
LEARNING_RATE = 3e-4  # Adam
VALUE_WEIGHT = 0.25  # the value loss's weight beside the policy loss
EPOCHS_PER_ROUND = 2  # passes over the aggregate data set after each round's collection
MIN_ROUNDS_TO_STOP = 2  # agreement ends the distillation only once the student has driven a round
MAX_EPISODE_STEPS = 3000  # [steps] 200 simulated seconds: more than a lap of any track at 0.5 m/s
EVAL_BATCH = 256  # frames per forward pass when labelling or measuring (no gradients)
TEACHER_STARTS = 8  # round 1: starts spread round the lap, for the greedy and for the sampled drives
STUDENT_STARTS = 12  # later rounds: starts spread round the lap for the student's drives
FROM_THE_LINE = 2  # episodes from the start line in every round (the states an evaluation visits)

Observation = dict[str, np.ndarray]  # a batch of observations as the policy reads them, by key
PLAIN = ""  # the key of a plain (camera-only) observation


@dataclass(frozen=True)
class DistillReport:
    """How close the student came to the teacher.

    :param agreement: on held-out frames, the share where the student picks the teacher's most
        probable action (discrete), or where both action dimensions of its mean are within
        :data:`ACTION_TOLERANCE` of the teacher's (continuous, in the normalised box).
    :param mean_action_error: continuous: mean ``|student mean - teacher mean|`` in box units;
        discrete: mean total-variation distance between the two action distributions.
    :param value_r2: R^2 of the student's value head against the teacher's on held-out frames.
    :param frames: distinct frames trained on (held-out frames not counted).
    :param rounds: data-collection rounds (the first driven by the teacher, the rest by the student).
    :param seconds: wall time of the distillation.
    """

    agreement: float
    mean_action_error: float
    value_r2: float
    frames: int
    rounds: int
    seconds: float

    def to_dict(self) -> dict[str, float | int]:
        """The report as JSON-friendly numbers."""
        return dataclasses.asdict(self)


@dataclass(frozen=True)
class _Drive:
    """One episode to drive while collecting frames.

    :param start: where it starts, as a fraction of the lap from the start line.
    :param driver: ``teacher`` or ``student``.
    :param sample: drive with sampled actions instead of the most probable.
    """

    start: float
    driver: str
    sample: bool = False


@dataclass
class _Labels:
    """What the teacher says about a batch of frames.

    :param targets: discrete: action probabilities (N, actions); continuous: means clipped to the box (N, 2).
    :param values: the teacher's values (N,).
    """

    targets: np.ndarray
    values: np.ndarray


class _FrameSet:
    """Frames (as the policy reads them: channel-first, uint8) with the teacher's labels."""

    def __init__(self) -> None:
        self._parts: list[tuple[Observation, _Labels]] = []
        self.obs: Observation = {}
        self.labels = _Labels(np.zeros((0,)), np.zeros((0,), np.float32))

    def __len__(self) -> int:
        return int(self.labels.values.shape[0]) + sum(len(p[1].values) for p in self._parts)

    def add(self, obs: Observation, labels: _Labels) -> None:
        """Add an episode's frames (joined to the rest by :meth:`pack`)."""
        self._parts.append((obs, labels))

    def pack(self) -> None:
        """Join the frames added since the last call into one array per key (done once a round)."""
        if not self._parts:
            return
        parts = self._parts if not self.obs else [(self.obs, self.labels), *self._parts]
        self.obs = {k: np.concatenate([p[0][k] for p in parts]) for k in parts[0][0]}
        self.labels = _Labels(
            np.concatenate([p[1].targets for p in parts]), np.concatenate([p[1].values for p in parts])
        )
        self._parts = []

    def batch(self, index: np.ndarray) -> tuple[Observation, _Labels]:
        """The frames at ``index`` (after :meth:`pack`)."""
        obs = {k: v[index] for k, v in self.obs.items()}
        return obs, _Labels(self.labels.targets[index], self.labels.values[index])


@dataclass(frozen=True)
class _Scores:
    """The student against the teacher on the held-out frames."""

    agreement: float
    mean_action_error: float
    value_r2: float


def distill_policy(
    teacher: BasePolicy,
    vehicle: Vehicle,
    make_env: Callable[[], gym.Env],
    *,
    seed: int = 0,
    max_seconds: float = 300.0,
    target_agreement: float = 0.98,
    on_progress: Callable[[str], None] | None = None,
) -> tuple[BasePolicy, DistillReport]:
    """Teach DeepRacer's ``shallow`` network to drive as ``teacher`` does (see the module docstring).

    :param teacher: the trained PPO policy (:func:`drx.train.policy_weights.load_policy_weights`).
    :param vehicle: the teacher's car; the student is built for the same car with the ``shallow`` network.
    :param make_env: returns the model's environment (its track, direction, race and car), to drive.
    :param seed: seeds the student's initial weights, the episodes' noise and the minibatches.
    :param max_seconds: wall-time budget, collection and training together.
    :param target_agreement: stop once the held-out agreement reaches this (after a round the student drove).
    :param on_progress: called with a sentence after every collection round and every epoch.
    :return: the student (evaluation mode, CPU) and the report.
    :raises DrxError: the teacher is not a PPO (actor-critic) policy, or does not fit the car.
    """
    started = time.monotonic()
    deadline = started + max_seconds
    say = on_progress or (lambda _message: None)
    teacher_ac = _actor_critic(teacher)
    with _torch_state(seed):
        student = _actor_critic(build_policy(dataclasses.replace(vehicle, network=STUDENT_NETWORK), "ppo"))
        _check_spaces(teacher_ac, student)
        if isinstance(student.action_space, spaces.Box):
            student.log_std.data.copy_(teacher_ac.log_std.data)  # the spread is state-independent: copied
        scores, rounds, frames = _rounds(
            teacher_ac, student, make_env, np.random.default_rng(seed), deadline, target_agreement, say
        )
        student.set_training_mode(False)
    report = DistillReport(
        agreement=scores.agreement,
        mean_action_error=scores.mean_action_error,
        value_r2=scores.value_r2,
        frames=frames,
        rounds=rounds,
        seconds=time.monotonic() - started,
    )
    return student, report


def _rounds(
    teacher: ActorCriticPolicy,
    student: ActorCriticPolicy,
    make_env: Callable[[], gym.Env],
    rng: np.random.Generator,
    deadline: float,
    target_agreement: float,
    say: Callable[[str], None],
) -> tuple[_Scores, int, int]:
    """DAgger's rounds: collect, then train on everything collected, until the target or the deadline.

    When the time left is shorter than the last round took, a new round's frames would hardly be
    trained on, so the rest of the time trains on the frames there are instead.

    :return: the last held-out scores, the rounds and the frames trained on.
    """
    trained, held_out = _FrameSet(), _FrameSet()
    optimizer = th.optim.Adam(_trainable(student), lr=LEARNING_RATE)
    scores, rounds, episodes = _Scores(0.0, 1.0, 0.0), 0, 0
    env = make_env()
    try:
        while time.monotonic() < deadline:
            began = time.monotonic()
            rounds += 1
            drives = _plan(rounds, rng)
            episodes = _collect(env, drives, teacher, student, rng, trained, held_out, episodes, deadline)
            say(f"round {rounds}: {len(trained)} frames to train on, {len(held_out)} held out")
            if rounds == 1:
                _start_value_head(student, trained.labels.values)
            train = _Training(student, optimizer, trained, held_out, rng, deadline, rounds, say)
            scores, reached = train.epochs(EPOCHS_PER_ROUND, target_agreement)
            if reached:
                break
            if deadline - time.monotonic() < time.monotonic() - began:
                scores, _ = train.epochs(None, target_agreement)
                break
    finally:
        env.close()
    return scores, rounds, len(trained)


# ----- set-up ------------------------------------------------------------------------------------------


@contextlib.contextmanager
def _torch_state(seed: int) -> Iterator[None]:
    """Seed torch for the student's initial weights and run it on :func:`_threads`; give back torch's
    random state and thread count afterwards."""
    threads = th.get_num_threads()
    with th.random.fork_rng(devices=[]):
        th.manual_seed(seed)
        th.set_num_threads(_threads())
        try:
            yield
        finally:
            th.set_num_threads(threads)


def _actor_critic(policy: BasePolicy) -> ActorCriticPolicy:
    """``policy`` as the PPO policy it must be (SAC's policies have no value head to distil)."""
    if not isinstance(policy, ActorCriticPolicy):
        raise DrxError(
            f"Only PPO policies can be distilled into DeepRacer's network; got {type(policy).__name__}."
        )
    return policy


def _check_spaces(teacher: ActorCriticPolicy, student: ActorCriticPolicy) -> None:
    """The student must read and act as the teacher does (same car)."""
    if teacher.action_space != student.action_space or teacher.observation_space != student.observation_space:
        raise DrxError(
            f"The teacher's spaces ({teacher.observation_space}, {teacher.action_space}) are not the car's "
            f"({student.observation_space}, {student.action_space}); distil it with the car it was "
            "trained for."
        )


def _trainable(student: ActorCriticPolicy) -> list[th.nn.Parameter]:
    """The parameters distillation trains: everything but the copied ``log_std``."""
    log_std = getattr(student, "log_std", None)
    return [p for p in student.parameters() if p is not log_std]


def _start_value_head(student: ActorCriticPolicy, values: np.ndarray) -> None:
    """Start the student's value head at the teacher's mean value, flat.

    Initialised as SB3 does, the head's outputs are off by the teacher's whole value (a reward of
    50-120 a step gives values of tens); that error's gradient, through the trunk the value head
    shares with the policy, swamped the policy's in the first epoch (losses of 5-40 against 0.3).
    """
    if len(values) == 0:
        return
    with th.no_grad():
        student.value_net.weight.zero_()
        student.value_net.bias.fill_(float(np.mean(values)))


def _threads() -> int:
    """Torch threads for the distillation: one, unless ``$DRX_TORCH_THREADS`` says more.

    Collecting runs the networks on one frame at a time, which more threads do not speed up. For
    the student's update a second thread pays only on an idle machine, and little there (a
    ``shallow`` minibatch of 64: 98-138 ms on two threads against 159 ms on one,
    ``docs/TRAINING.md``); on this 2-core machine shared with other jobs (load 6) it measured 133
    against 127 ms. Where OpenMP's threads spin (torch imported before ``drx.train`` set
    ``OMP_WAIT_POLICY=PASSIVE``) two threads took 620 ms against 110. One thread also gives the
    same student on any machine, whatever its cores.
    """
    explicit = os.environ.get("DRX_TORCH_THREADS", "").strip()
    return useful_threads(STUDENT_NETWORK, int(explicit)) if explicit.isdigit() and int(explicit) > 0 else 1


# ----- the heads ---------------------------------------------------------------------------------------


def _heads(policy: ActorCriticPolicy, obs: Observation) -> tuple[th.Tensor, th.Tensor]:
    """The action head's output (logits, or the Gaussian's mean) and the value, for a batch of frames."""
    tensors = {k: th.as_tensor(v, device=policy.device) for k, v in obs.items()}
    features = policy.extract_features(tensors.get(PLAIN, tensors))
    if isinstance(features, tuple):  # separate actor and critic extractors
        latent_pi = policy.mlp_extractor.forward_actor(features[0])
        latent_vf = policy.mlp_extractor.forward_critic(features[1])
    else:
        latent_pi, latent_vf = policy.mlp_extractor(features)
    return policy.action_net(latent_pi), policy.value_net(latent_vf).squeeze(-1)


def _targets(action_out: th.Tensor, discrete: bool) -> th.Tensor:
    """What drives: the action probabilities, or the mean clipped to the box (a mean past a bound
    drives as the bound does)."""
    return th.softmax(action_out, dim=-1) if discrete else action_out.clamp(-1.0, 1.0)


def _label(teacher: ActorCriticPolicy, obs: Observation) -> _Labels:
    """The teacher's targets and values for a batch of frames."""
    discrete = isinstance(teacher.action_space, spaces.Discrete)
    n = len(next(iter(obs.values())))
    targets, values = [], []
    with th.no_grad():
        for lo in range(0, n, EVAL_BATCH):
            out, value = _heads(teacher, {k: v[lo : lo + EVAL_BATCH] for k, v in obs.items()})
            targets.append(_targets(out, discrete).cpu().numpy().astype(np.float32))
            values.append(value.cpu().numpy().astype(np.float32))
    return _Labels(np.concatenate(targets), np.concatenate(values))


def _as_policy_obs(policy: ActorCriticPolicy, observation: np.ndarray | dict[str, np.ndarray]) -> Observation:
    """One env observation as a batch of one, channel-first as the policy reads it."""
    tensor, _ = policy.obs_to_tensor(observation)
    if isinstance(tensor, dict):
        return {k: v.cpu().numpy() for k, v in tensor.items()}
    return {PLAIN: tensor.cpu().numpy()}


# ----- collecting frames (DAgger) ----------------------------------------------------------------------


def _plan(round_number: int, rng: np.random.Generator) -> list[_Drive]:
    """The episodes of a round: the teacher drives the first, the student the later ones.

    Every round drives from the start line (what an evaluation sees) and from starts spread round
    the lap (a random offset per round, so rounds see different places); the teacher also drives
    with its sampled actions, whose wobbles show it recovering from states off its own line.
    """
    line = [0.0] * FROM_THE_LINE
    if round_number == 1:
        spread = _spread(TEACHER_STARTS, rng)
        drives = [_Drive(s, "teacher") for s in line]
        for s in spread:
            drives += [_Drive(s, "teacher"), _Drive((s + 0.5 / TEACHER_STARTS) % 1.0, "teacher", sample=True)]
        return drives
    return [_Drive(s, "student") for s in [*line, *_spread(STUDENT_STARTS, rng)]]


def _spread(n: int, rng: np.random.Generator) -> list[float]:
    """``n`` starts evenly round the lap, all shifted by one random offset."""
    offset = float(rng.random()) / n
    return [offset + k / n for k in range(n)]


def _collect(
    env: gym.Env,
    drives: list[_Drive],
    teacher: ActorCriticPolicy,
    student: ActorCriticPolicy,
    rng: np.random.Generator,
    trained: _FrameSet,
    held_out: _FrameSet,
    episodes: int,
    deadline: float,
) -> int:
    """Drive the planned episodes; every frame labelled by the teacher goes to ``trained`` or, for
    every :data:`HELD_OUT_EVERY`-th episode, to ``held_out``. Returns the episodes driven so far."""
    for drive in drives:
        if time.monotonic() >= deadline:
            break
        driver = teacher if drive.driver == "teacher" else student
        obs = _drive(env, driver, drive, rng, deadline)
        episodes += 1
        target = held_out if episodes % HELD_OUT_EVERY == 0 else trained
        target.add(obs, _label(teacher, obs))
    trained.pack()
    held_out.pack()
    return episodes


def _drive(
    env: gym.Env, driver: ActorCriticPolicy, drive: _Drive, rng: np.random.Generator, deadline: float
) -> Observation:
    """One episode driven by ``driver``; returns the frames it saw (before each action)."""
    discrete = isinstance(driver.action_space, spaces.Discrete)
    observation, _ = env.reset(seed=int(rng.integers(2**31)), options={"start": drive.start})
    frames: list[Observation] = []
    for _step in range(MAX_EPISODE_STEPS):
        obs = _as_policy_obs(driver, observation)
        frames.append(obs)
        with th.no_grad():
            out, _value = _heads(driver, obs)
        action = _action(driver, out[0], discrete, drive.sample, rng)
        observation, _reward, terminated, truncated, _info = env.step(action)
        if terminated or truncated or time.monotonic() >= deadline:
            break
    return {k: np.concatenate([f[k] for f in frames]) for k in frames[0]}


def _action(
    policy: ActorCriticPolicy, out: th.Tensor, discrete: bool, sample: bool, rng: np.random.Generator
) -> int | np.ndarray:
    """The action to take: the most probable, or one sampled from the policy's distribution."""
    if discrete:
        probs = th.softmax(out, dim=-1).cpu().numpy().astype(np.float64)
        return int(rng.choice(len(probs), p=probs / probs.sum())) if sample else int(np.argmax(probs))
    mean = out.cpu().numpy().astype(np.float64)
    if sample:
        std = np.exp(policy.log_std.detach().cpu().numpy().astype(np.float64))
        mean = mean + std * rng.standard_normal(mean.shape)
    return np.clip(mean, -1.0, 1.0).astype(np.float32)


# ----- training ----------------------------------------------------------------------------------------


@dataclass
class _Training:
    """The student's training on the aggregate after one round's collection.

    :param round_number: the round (for progress and for :data:`MIN_ROUNDS_TO_STOP`).
    """

    student: ActorCriticPolicy
    optimizer: th.optim.Optimizer
    trained: _FrameSet
    held_out: _FrameSet
    rng: np.random.Generator
    deadline: float
    round_number: int
    say: Callable[[str], None]

    def epochs(self, count: int | None, target_agreement: float) -> tuple[_Scores, bool]:
        """Train ``count`` epochs (``None``: until the deadline), scoring the student on the held-out
        frames after each; returns the last scores and whether they reached ``target_agreement``."""
        scores = _score(self.student, self.held_out)
        value_scale = _value_scale(self.trained.labels.values)
        epoch = 0
        while (count is None or epoch < count) and len(self.trained) and time.monotonic() < self.deadline:
            epoch += 1
            loss = _epoch(self.student, self.optimizer, self.trained, self.rng, self.deadline, value_scale)
            scores = _score(self.student, self.held_out)
            self.say(
                f"round {self.round_number}, epoch {epoch}{f'/{count}' if count else ''}: loss {loss:.4f}, "
                f"held-out agreement {scores.agreement:.3f}, action error {scores.mean_action_error:.3f}, "
                f"value R^2 {scores.value_r2:.3f}"
            )
            if self.round_number >= MIN_ROUNDS_TO_STOP and scores.agreement >= target_agreement:
                return scores, True
        return scores, False


def _epoch(
    student: ActorCriticPolicy,
    optimizer: th.optim.Optimizer,
    frames: _FrameSet,
    rng: np.random.Generator,
    deadline: float,
    value_scale: float,
) -> float:
    """One pass over ``frames`` in shuffled minibatches (cut at the deadline); returns the mean loss."""
    discrete = isinstance(student.action_space, spaces.Discrete)
    student.set_training_mode(True)
    order = rng.permutation(len(frames))
    losses = []
    for lo in range(0, len(order), BATCH_SIZE):
        if time.monotonic() >= deadline:
            break
        obs, labels = frames.batch(np.sort(order[lo : lo + BATCH_SIZE]))  # sorted: faster gathers
        out, values = _heads(student, obs)
        loss = _loss(out, values, labels, discrete, value_scale)
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
        losses.append(float(loss.detach()))
    student.set_training_mode(False)
    return float(np.mean(losses)) if losses else float("nan")


def _value_scale(values: np.ndarray) -> float:
    """What the value's squared error is divided by: the variance of the teacher's values, so that the
    value loss weighs the same whatever the reward's scale; at least 1% of their mean square, since
    an untrained teacher's values barely vary and would give the value loss a weight of thousands."""
    if len(values) == 0:
        return 1.0
    v = values.astype(np.float64)
    return max(float(np.var(v)), 0.01 * float(np.mean(v**2)), 1e-6)


def _loss(
    out: th.Tensor, values: th.Tensor, labels: _Labels, discrete: bool, value_scale: float
) -> th.Tensor:
    """The policy loss (cross-entropy against the teacher's probabilities, or the means' squared
    error) plus the value's squared error in units of the teacher's value variance."""
    targets = th.as_tensor(labels.targets, device=out.device)
    if discrete:
        policy_loss = -(targets * F.log_softmax(out, dim=-1)).sum(dim=-1).mean()
    else:
        policy_loss = F.mse_loss(out, targets)
    value_loss = F.mse_loss(values, th.as_tensor(labels.values, device=values.device)) / value_scale
    return policy_loss + VALUE_WEIGHT * value_loss


# ----- scoring -----------------------------------------------------------------------------------------


def _score(student: ActorCriticPolicy, held_out: _FrameSet) -> _Scores:
    """Agreement, action error and value R^2 of the student on the held-out frames."""
    n = len(held_out)
    if n == 0:
        return _Scores(0.0, 1.0, 0.0)
    discrete = isinstance(student.action_space, spaces.Discrete)
    predicted = _label(student, held_out.obs)
    return _compare(predicted, held_out.labels, discrete)


def _compare(student: _Labels, teacher: _Labels, discrete: bool) -> _Scores:
    """The report's figures from the student's and the teacher's labels of the same frames."""
    if discrete:
        agree = np.argmax(student.targets, axis=1) == np.argmax(teacher.targets, axis=1)
        error = 0.5 * np.abs(student.targets - teacher.targets).sum(axis=1)  # total variation
    else:
        gap = np.abs(student.targets - teacher.targets)
        agree = (gap <= ACTION_TOLERANCE).all(axis=1)
        error = gap.mean(axis=1)
    return _Scores(float(agree.mean()), float(error.mean()), _r2(student.values, teacher.values))


def _r2(predicted: np.ndarray, truth: np.ndarray) -> float:
    """The coefficient of determination of ``predicted`` against ``truth`` (1 = exact; 0 = the mean's)."""
    residual = float(np.sum((truth.astype(np.float64) - predicted) ** 2))
    total = float(np.sum((truth.astype(np.float64) - truth.mean()) ** 2))
    if total == 0.0:
        return 1.0 if residual == 0.0 else 0.0
    return 1.0 - residual / total
