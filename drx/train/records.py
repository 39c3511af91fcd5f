"""What a training run reports: episodes, iterations, checkpoints, and the sink that receives them.

The trainer knows nothing of the registry or the terminal. It hands these
plain records to a :class:`TrainingSink`; the job runner's sink writes them to
the registry, the CLI's sink draws the dashboard, tests keep them in lists.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any, Protocol

from drx.sim.episode_status import EpisodeStatus

TRAINING = "training"
EVALUATION = "evaluation"


@dataclass
class EpisodeRecord:
    """One finished episode.

    :param iteration: the iteration it belongs to (0-based, as DeepRacer's trace files).
    :param episode: its index within the iteration and phase.
    :param global_episode: for training, the model's running episode number (the trace's ``episode``).
    :param phase: ``training`` or ``evaluation``.
    :param reward: sum of rewards.
    :param progress: [%] lap progress reached.
    :param steps: steps taken.
    :param status: DeepRacer's ``episode_status`` at the end (``lap_complete``, ``off_track``...).
    :param lap_time: [s] simulated lap time when the lap completed.
    :param start_fraction: [0, 1) where on the lap it started.
    :param wall_seconds: wall-clock seconds it took.
    :param track: the route it drove (the env's ``info["track"]``: a model's training env says it),
        ``None`` when the env did not say (the evaluation's: the model's first track).
    """

    iteration: int
    episode: int
    global_episode: int
    phase: str
    reward: float
    progress: float
    steps: int
    status: str
    lap_time: float | None = None
    start_fraction: float = 0.0
    wall_seconds: float = 0.0
    track: str | None = None

    @property
    def complete(self) -> bool:
        """Whether the lap was completed (100% progress)."""
        return self.progress >= 100.0 - 1e-6 or self.status == EpisodeStatus.LAP_COMPLETE


@dataclass
class TrackFigures:
    """One track's training episodes of an iteration (a model training on several tracks).

    :param episodes: how many.
    :param mean_reward: their mean total reward.
    :param mean_progress: [%] their mean progress.
    """

    episodes: int
    mean_reward: float | None
    mean_progress: float | None


def figures_by_track(records: list[EpisodeRecord]) -> dict[str, TrackFigures]:
    """The training records' figures per track, in the order the tracks first drove; empty unless
    they drove more than one track (a one-track model's figures are the iteration's own)."""
    groups: dict[str, list[EpisodeRecord]] = {}
    for r in records:
        if r.phase == TRAINING and r.track is not None:
            groups.setdefault(r.track, []).append(r)
    if len(groups) < 2:
        return {}
    return {
        name: TrackFigures(
            len(rs), mean_or_none([r.reward for r in rs]), mean_or_none([r.progress for r in rs])
        )
        for name, rs in groups.items()
    }


def describe_by_track(by_track: dict[str, TrackFigures]) -> str:
    """``reInvent2019_wide_cw 12.3 / 45%, oval 10.1 / 60%`` (training reward / progress per track)."""

    def num(value: float | None, spec: str) -> str:
        return "-" if value is None else f"{value:{spec}}"

    return ", ".join(
        f"{name} {num(f.mean_reward, '.1f')} / {num(f.mean_progress, '.0f')}%" for name, f in by_track.items()
    )


@dataclass
class IterationSummary:
    """Figures of one iteration, as stored in ``iteration_metrics`` and drawn by the dashboard.

    Totals (``steps``, ``episodes``, ``elapsed_seconds``) are the model's, across resumed attempts.
    """

    iteration: int
    steps: int
    episodes: int
    elapsed_seconds: float
    steps_per_second: float
    train_mean_reward: float | None
    train_mean_progress: float | None
    eval_mean_reward: float | None
    eval_mean_progress: float | None
    eval_laps_complete: int = 0
    eval_episodes: int = 0
    eval_best_lap_time: float | None = None
    eval_mean_lap_time: float | None = None  # [s] when every evaluation lap completed
    policy_loss: float | None = None
    value_loss: float | None = None
    entropy: float | None = None
    kl: float | None = None
    learning_rate: float | None = None
    extra: dict[str, float] = field(default_factory=dict)
    # What tells a healthy run from a dying one (drx.train.algorithms.HEALTH_FIGURES): PPO's clip
    # fraction, explained variance, return scale and epochs run; SAC's reward scale; and for both
    # the Gaussian's spread and the shares of sampled actions on a bound. Those two are measured
    # alike but not on the same actions: PPO's spread is of its state-independent log-std and its
    # shares are of the actions it explored with (clipped to the box); SAC's spread is the
    # geometric mean of its state-dependent std before the tanh, and its shares are of the
    # squashed actions its update samples (past 0.99 of a bound).
    health: dict[str, float] = field(default_factory=dict)
    # training reward and progress per track, when the iteration drove several (figures_by_track)
    by_track: dict[str, TrackFigures] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly dict."""
        return asdict(self)


@dataclass
class CheckpointRecord:
    """A checkpoint written after an iteration.

    :param iteration: the iteration whose update it holds.
    :param path: the ``last`` checkpoint file.
    :param best_path: the ``best`` file when this checkpoint is the best so far, else ``None``.
    """

    iteration: int
    path: str
    steps: int
    episodes: int
    eval_progress: float | None
    eval_lap_time: float | None
    is_best: bool
    best_path: str | None = None


class TrainingSink(Protocol):
    """Receives a run's records as they happen."""

    def on_episode(self, record: EpisodeRecord) -> None:
        """An episode ended."""

    def on_iteration(self, summary: IterationSummary, episodes: list[EpisodeRecord]) -> None:
        """An iteration ended (after its update and evaluation, before its checkpoint)."""

    def on_checkpoint(self, record: CheckpointRecord) -> None:
        """A checkpoint was written; the iteration is now durable."""

    def on_step(self, steps: int) -> None:
        """Called every few dozen steps with the running step count (cheap: for live displays)."""

    def stop_requested(self) -> bool:
        """Whether someone asked the run to stop (polled often; must be cheap)."""

    def on_discard(self, iteration: int) -> None:
        """An iteration was cut before it became durable: forget what was reported for it."""

    def on_phase(self, phase: str, elapsed: float) -> None:
        """The run entered a phase (:data:`SAMPLING`, ``updating the policy: epoch 3/10``,
        :data:`EVALUATING`, :data:`SAVING`); ``elapsed`` [s] is the job's wall time so far."""


# The phases a run goes through (the update's is "updating the policy: epoch e/E").
SAMPLING = "sampling episodes"
EVALUATING = "evaluating"
SAVING = "saving a checkpoint"
STARTING = "starting"


def updating(epoch: int, epochs: int) -> str:
    """The update's phase."""
    return f"updating the policy: epoch {epoch}/{epochs}"


class NullSink:
    """A sink that ignores everything."""

    def on_episode(self, record: EpisodeRecord) -> None:
        """Ignore."""

    def on_iteration(self, summary: IterationSummary, episodes: list[EpisodeRecord]) -> None:
        """Ignore."""

    def on_checkpoint(self, record: CheckpointRecord) -> None:
        """Ignore."""

    def on_step(self, steps: int) -> None:
        """Ignore."""

    def stop_requested(self) -> bool:
        """Never."""
        return False

    def on_discard(self, iteration: int) -> None:
        """Ignore."""

    def on_phase(self, phase: str, elapsed: float) -> None:
        """Ignore."""


class MultiSink:
    """Forwards every record to several sinks; stop is requested when any of them asks.

    :param sinks: the sinks, called in order.
    """

    def __init__(self, *sinks: TrainingSink) -> None:
        self.sinks = list(sinks)

    def on_episode(self, record: EpisodeRecord) -> None:
        """Forward."""
        for s in self.sinks:
            s.on_episode(record)

    def on_iteration(self, summary: IterationSummary, episodes: list[EpisodeRecord]) -> None:
        """Forward."""
        for s in self.sinks:
            s.on_iteration(summary, episodes)

    def on_checkpoint(self, record: CheckpointRecord) -> None:
        """Forward."""
        for s in self.sinks:
            s.on_checkpoint(record)

    def on_step(self, steps: int) -> None:
        """Forward."""
        for s in self.sinks:
            s.on_step(steps)

    def stop_requested(self) -> bool:
        """Any sink asks."""
        return any(s.stop_requested() for s in self.sinks)

    def on_discard(self, iteration: int) -> None:
        """Forward."""
        for s in self.sinks:
            s.on_discard(iteration)

    def on_phase(self, phase: str, elapsed: float) -> None:
        """Forward (to the sinks that show phases)."""
        for s in self.sinks:
            hook = getattr(s, "on_phase", None)
            if hook is not None:
                hook(phase, elapsed)


def mean_or_none(values: list[float]) -> float | None:
    """Arithmetic mean, ``None`` for an empty list."""
    finite = [v for v in values if v is not None and math.isfinite(v)]
    return sum(finite) / len(finite) if finite else None
