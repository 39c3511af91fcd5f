"""The training loop: iterations of episodes, updates, evaluations and checkpoints.

One iteration, as the DeepRacer console runs it:

1. the policy drives ``episodes_per_iteration`` whole training episodes (the
   environment moves each one's start 5% further along the track);
2. one policy update on that experience;
3. a few evaluation episodes from the start line with the most probable action;
4. a checkpoint (``last``, and ``best`` when the evaluation beats every earlier one),
   after which the iteration is durable. Under the ``anneal`` schedule (drx's default) an
   iteration that ends three in a row slower than the best loads the best's weights back and
   halves the learning rate first (:mod:`drx.train.anneal`), so ``last`` holds them.

Stop conditions are checked after every step; when one hits mid-iteration the
whole episodes collected so far still make an iteration (update, evaluation,
checkpoint). A run restarted on the same model folder resumes from ``last``.

``max_minutes`` is wall time since the job started (``TrainingSpec.started``) and holds
within :meth:`StopWatch.overshoot_allowed` whatever the network: the update is asked
before every minibatch and ends there at the limit (or, when sampling already reached it,
half the allowed overshoot past it), a run past its limit skips the evaluation, and the
``last`` checkpoint is written either way. The sink hears each phase (``on_phase``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym
import torch as th

from drx.atomic import copy_atomic, write_json_atomic
from drx.settings.hyperparameters import ANNEAL, Hyperparameters
from drx.settings.stop import StopConditions
from drx.sim.env import DeepRacerEnv
from drx.sim.schedule import ScheduledEnv
from drx.train import algorithms
from drx.train.anneal import AnnealState, best_lap_time, judge
from drx.train.checkpoint import (
    checkpoint_path,
    is_better,
    load_weights,
    read_meta,
    remove_stale_temporaries,
    save_checkpoint,
)
from drx.train.device import device_label, resolve_device
from drx.train.evaluation import evaluate
from drx.train.networks import useful_threads
from drx.train.ppo import EpisodicPPO
from drx.train.records import (
    EVALUATING,
    SAMPLING,
    SAVING,
    TRAINING,
    CheckpointRecord,
    EpisodeRecord,
    IterationSummary,
    NullSink,
    TrainingSink,
    figures_by_track,
    mean_or_none,
    updating,
)
from drx.train.rollout import RolloutWorkers
from drx.train.run_state import RunState
from drx.train.stop import INTERRUPTED, OVERSHOOT_SECONDS, REQUESTED, StopRequested, StopWatch
from drx.train.trace import STEP_SECONDS, EpisodeTracker, TraceWriter
from drx.vehicle import Vehicle

# (mode) -> env, mode being "training" or "evaluation".
EnvFactory = Callable[[str], gym.Env]
SINK_EVERY = 32  # [steps] how often the sink hears about progress and is asked about stop requests
EVAL_EPISODES = 3


@dataclass
class TrainingSpec:
    """Everything one training run needs.

    :param vehicle: the car (action space, sensors, network).
    :param hyperparameters: DeepRacer hyperparameters.
    :param stop: stop conditions for this run.
    :param folder: the model's artifacts folder (checkpoints, traces, metadata).
    :param env_factory: builds the environment for a mode (``training`` / ``evaluation``).
    :param eval_episodes: evaluation episodes after each iteration.
    :param seed: random seed.
    :param init_checkpoint: a checkpoint to start from when the folder has none (a clone's parent's).
    :param run_key: identifies the job; a resumed attempt of the same job keeps its stop-condition counters.
    :param threads: torch threads the run may use (``None``: torch's setting); the compact
        network uses one (see :data:`drx.train.networks.USEFUL_THREADS`).
    :param rollout_workers: processes sampling the training episodes (1: in this process;
        PPO only, SAC samples in this process). See :mod:`drx.train.rollout`.
    :param started: ``time.monotonic()`` when the job started; ``max_minutes`` and the elapsed
        time count from there (``None``: from when the trainer is built).
    :param device: the torch device the update runs on (and this process's sampling and
        evaluation): ``cpu``, ``cuda``, ``cuda:N``, ``mps``, or ``None`` for ``auto``
        (:func:`drx.train.device.resolve_device`; rollout workers sample on their CPU).
    :param simulator: the DeepRacer simulator whose car it trains on (``model_metadata.json``'s
        ``version``; the env factory builds that car).
    """

    vehicle: Vehicle
    hyperparameters: Hyperparameters
    stop: StopConditions
    folder: Path
    env_factory: EnvFactory
    eval_episodes: int = EVAL_EPISODES
    seed: int | None = None
    init_checkpoint: Path | None = None
    run_key: str | None = None
    threads: int | None = None
    rollout_workers: int = 1
    started: float | None = None
    device: str | None = "cpu"
    simulator: str = "5"


@dataclass
class TrainingResult:
    """How a run ended.

    :param stop_reason: the stop condition or request that ended it.
    :param iterations: iterations completed in this run.
    :param steps: the model's total training steps.
    :param episodes: the model's total training episodes.
    :param best: the best checkpoint's run state (``None`` when no iteration completed).
    :param last_iteration: the last durable iteration (-1 when none).
    """

    stop_reason: str | None
    iterations: int
    steps: int
    episodes: int
    best: dict[str, Any] | None
    last_iteration: int
    summaries: list[IterationSummary] = field(default_factory=list)


class Trainer:
    """Runs :class:`TrainingSpec` to a stop condition.

    :param spec: what to train.
    :param sink: receives episodes, iterations and checkpoints as they happen.
    """

    def __init__(self, spec: TrainingSpec, sink: TrainingSink | None = None) -> None:
        self.started = time.monotonic() if spec.started is None else float(spec.started)
        self.device = resolve_device(spec.device)  # first: a GPU this machine lacks fails before any work
        self.spec = spec
        self.sink: TrainingSink = sink or NullSink()
        available = max(1, int(spec.threads)) if spec.threads else th.get_num_threads()
        self.threads = useful_threads(spec.vehicle.network, available)
        th.set_num_threads(self.threads)
        self.folder = Path(spec.folder)
        self.train_env = spec.env_factory("training")
        self.eval_env = spec.env_factory("evaluation")
        self.model = algorithms.build_algorithm(
            self.train_env, spec.vehicle.network, spec.hyperparameters, seed=spec.seed, device=self.device
        )
        self.trace = TraceWriter(self.folder, spec.vehicle.continuous)
        self.state = self._restore()
        if self.annealing:  # a resumed run goes on at the rate its rollbacks reached
            self.model.set_lr_factor(self.state.lr_factor)
        self._continue_round_robin(self.state.episodes)
        self.workers: RolloutWorkers | None = None
        if spec.rollout_workers > 1 and isinstance(self.model, EpisodicPPO):
            self.workers = RolloutWorkers(spec.env_factory, spec.rollout_workers, seed=spec.seed)
            # Waits for the workers to start and build their policy, so that an iteration's
            # time is sampling, not start-up.
            self.workers.set_policy(self.model.policy, self.model.bootstrap_factor)
        self.watch = StopWatch(
            spec.stop,
            elapsed=self.state.job_elapsed,
            steps=self.state.job_steps,
            episodes=self.state.job_episodes,
            streak=self.state.streak,
        )

    # ----- state -----------------------------------------------------------
    @property
    def annealing(self) -> bool:
        """Whether the run follows the ``anneal`` schedule (:mod:`drx.train.anneal`)."""
        return self.spec.hyperparameters.lr_schedule == ANNEAL

    def _restore(self) -> RunState:
        """Load ``last`` (resume) or the initial checkpoint (clone); return the run state."""
        state = RunState()
        remove_stale_temporaries(self.folder)
        last = checkpoint_path(self.folder, "last")
        if last.is_file():
            load_weights(self.model, last)
            meta = read_meta(last)
            best = checkpoint_path(self.folder, "best")
            same_job = meta.get("run_key") is not None and meta.get("run_key") == self.spec.run_key
            state = RunState.resumed(meta, read_meta(best) if best.is_file() else None, same_job)
            self._restore_reward_scale(meta)
        elif self.spec.init_checkpoint is not None:
            load_weights(self.model, Path(self.spec.init_checkpoint))
            self._restore_reward_scale(read_meta(Path(self.spec.init_checkpoint)))
        self._write_model_files()
        return state

    def _restore_reward_scale(self, meta: dict[str, Any]) -> None:
        """A resumed or cloned run goes on with the scale its rewards were divided by (PPO's value
        head and SAC's critics predict returns in its units, :mod:`drx.train.stability`).

        A SAC checkpoint without one predates drx's shared encoder (:mod:`drx.train.sac`): its
        actor head was trained on the actor's own encoder, which the critics then adopt."""
        if isinstance(self.model, EpisodicPPO):
            self.model.return_scale.restore(meta.get("return_scale"))
        elif "reward_scale" in meta:
            self.model.reward_scale.restore(meta["reward_scale"])
        else:
            self.model.adopt_actor_encoder()

    def _continue_round_robin(self, episodes: int) -> None:
        """Start a resumed run where the round robin of training starts left off: the training
        env's next episode is the run's episode ``episodes`` (its reset option ``episode``)."""
        if episodes > 0 and isinstance(self.train_env.unwrapped, DeepRacerEnv | ScheduledEnv):
            venv = self.model.get_env()
            assert venv is not None
            venv.set_options({"episode": episodes})  # SB3's public way to pass the next reset's options
            # SB3 has no public call that restarts the algorithm's episode outside learn();
            # algorithms.setup (SB3's start of learning) resets the env and takes its first observation.
            algorithms.setup(self.model)

    def _write_model_files(self) -> None:
        hp = self.spec.hyperparameters
        metadata = self.spec.vehicle.to_model_metadata(hp.algorithm, self.spec.simulator)
        write_json_atomic(self.folder / "model" / "model_metadata.json", metadata)
        write_json_atomic(
            self.folder / "ip" / "hyperparameters.json", hp.to_deepracer_json(self.spec.stop.max_episodes)
        )

    # ----- the loop ----------------------------------------------------------
    def run(self) -> TrainingResult:
        """Train until a stop condition; return how it ended.

        A ``KeyboardInterrupt`` (or a stop request raised inside a slow reward call,
        :class:`drx.train.stop.StopRequested`) ends the run at once: the iteration in progress is
        dropped (the sink is told through ``on_discard`` when it has one) and the
        last checkpoint stays as it was.
        """
        summaries: list[IterationSummary] = []
        iteration = self.state.iteration + 1
        self.watch.start(self.started)
        try:
            while self._limits_ok():
                summary = self._iteration(iteration)
                if summary is None:
                    break
                summaries.append(summary)
                iteration += 1
        except (KeyboardInterrupt, StopRequested) as exc:
            self.trace.close()
            self._discard(iteration)
            self.watch.request(REQUESTED if isinstance(exc, StopRequested) else INTERRUPTED)
        finally:
            self.trace.close()
            self.close()
        return TrainingResult(
            stop_reason=self.watch.reason,
            iterations=len(summaries),
            steps=self.state.steps,
            episodes=self.state.episodes,
            best=self.state.best,
            last_iteration=self.state.iteration,
            summaries=summaries,
        )

    def close(self) -> None:
        """Stop the rollout workers (a finished run does; a trainer never run should be closed)."""
        if self.workers is not None:
            self.workers.close()
            self.workers = None

    def _limits_ok(self) -> bool:
        if self.sink.stop_requested():
            self.watch.request(REQUESTED)
        return self.watch.check_limits() is None and self.watch.reason is None

    def _phase(self, phase: str) -> None:
        """Tell the sink which phase the run is in (sinks without ``on_phase`` are skipped)."""
        hook = getattr(self.sink, "on_phase", None)
        if hook is not None:
            hook(phase, self.watch.elapsed)

    def _discard(self, iteration: int) -> None:
        (self.trace.folder / f"{iteration}-iteration.csv").unlink(missing_ok=True)
        self.sink.on_discard(iteration)

    def _iteration(self, iteration: int) -> IterationSummary | None:
        """Run one iteration; ``None`` when it was cut before any episode completed."""
        hp = self.spec.hyperparameters
        started = time.monotonic()
        steps_before = self.state.steps
        records: list[EpisodeRecord] = []
        tracker = EpisodeTracker(TRAINING)
        self.trace.start_iteration(iteration)
        vehicle = self.spec.vehicle

        def on_step(action: Any, reward: float, done: bool, info: dict[str, Any]) -> bool:
            st = self.state
            st.steps += 1
            st.sim_time += STEP_SECONDS
            self.watch.steps += 1
            tracker.step(reward, info)
            scaled = vehicle.scale_continuous(action) if vehicle.continuous else None
            self.trace.write(st.episodes, action, reward, done, info, st.sim_time, scaled)
            if done:
                rec = tracker.finish(info, iteration, len(records), st.episodes)
                records.append(rec)
                st.episodes += 1
                self.watch.episodes += 1
                self.trace.flush()
                self.sink.on_episode(rec)
            if st.steps % SINK_EVERY == 0:
                self.sink.on_step(st.steps)
                if self.sink.stop_requested():
                    self.watch.request(REQUESTED)
            return self.watch.reason is None and self.watch.check_limits() is None

        # One observation at a time gains nothing from more threads and loses a lot when the
        # cores are busy; the update's batches do gain.
        self._phase(SAMPLING)
        th.set_num_threads(1)
        try:
            if self.workers is not None:
                assert isinstance(self.model, EpisodicPPO)
                collected = self.model.collect_episodes_parallel(
                    self.workers, hp.episodes_per_iteration, self.state.episodes, on_step,
                    keep_going=self._keep_sampling,
                )  # fmt: skip
            elif isinstance(self.model, EpisodicPPO):  # one worker: the same episodes, in this process
                collected = self.model.collect_episodes_driven(
                    self.train_env, hp.episodes_per_iteration, self.state.episodes, self.spec.seed,
                    on_step,
                )  # fmt: skip
            else:
                collected = self.model.collect_episodes(hp.episodes_per_iteration, on_step)
        finally:
            th.set_num_threads(self.threads)
        self.trace.close()
        if collected.buffered_steps == 0 or not records:
            self._discard(iteration)
            return None
        train_seconds = time.monotonic() - started
        algorithms.set_progress(self.model, self.watch.progress())
        complete = algorithms.update(self.model, collected.buffered_steps, self._update_hook())
        update_seconds = time.monotonic() - started - train_seconds
        metrics, health = algorithms.update_metrics(self.model)
        self._check_finite(metrics, iteration)
        eval_records = self._evaluate(iteration)
        elapsed = time.monotonic() - started
        self.state.elapsed += elapsed
        summary = self._summary(
            iteration, records, eval_records, metrics, steps_before, elapsed, train_seconds
        )
        summary.health = health
        summary.extra.update(
            {"update_seconds": update_seconds, "eval_seconds": elapsed - train_seconds - update_seconds}
        )
        if not complete:
            summary.extra["update_cut"] = 1.0
        evaluated = len(eval_records) == self.spec.eval_episodes
        if self.annealing:  # before the sink hears of it (its summary says so) and before `last`
            self._anneal(iteration, summary, evaluated and bool(eval_records))
        self.sink.on_iteration(summary, records + eval_records)
        self.watch.record_evaluation(
            evaluated and bool(eval_records) and all(r.complete for r in eval_records)
        )
        self._phase(SAVING)
        self._checkpoint(iteration, summary, evaluated)
        return summary

    def _keep_sampling(self) -> bool:
        """Between the steps of parallel sampling: no limit reached, no stop asked."""
        if self.sink.stop_requested():
            self.watch.request(REQUESTED)
        return self.watch.reason is None and self.watch.check_limits() is None

    def _update_hook(self) -> Callable[[int, int], bool]:
        """The update's check before each minibatch: report the epoch, end it at the time limit.

        An update that starts before the limit ends at the limit; one that starts past it (the
        sampling ran to the limit) may go on for half the allowed overshoot, so that the
        episodes just sampled still teach the policy something. After a stop request the
        update goes on for at most half of :data:`OVERSHOOT_SECONDS`.
        """
        watch = self.watch
        grace = 0.0 if not watch.past_limit() else 0.5 * (watch.overshoot_allowed() or 0.0)
        shown = [0]
        requested_at: list[float] = []

        def on_batch(epoch: int, epochs: int) -> bool:
            if epoch != shown[0]:
                shown[0] = epoch
                self._phase(updating(epoch, epochs))
            if self.sink.stop_requested():
                watch.request(REQUESTED)
            if watch.reason == REQUESTED and not requested_at:
                requested_at.append(time.monotonic())
            if requested_at and time.monotonic() - requested_at[0] >= 0.5 * OVERSHOOT_SECONDS:
                return False
            if watch.past_limit(grace):
                watch.check_limits()
                return False
            return True

        return on_batch

    def _anneal(self, iteration: int, summary: IterationSummary, evaluated: bool) -> None:
        """Judge the iteration against the best checkpoint (:func:`drx.train.anneal.judge`); on a
        rollback, load the best's weights and reward scale and lower the learning rate.

        The summary's ``extra`` records the factor (``lr_factor``) and, on a rollback, the best's
        iteration (``rollback_to``), its lap time (``best_lap_time``) and the rate from the next
        update on (``next_learning_rate``). The ``last`` checkpoint written next holds the best's
        weights, which the run continues from.
        """
        st = self.state
        lap_time = summary.eval_mean_lap_time
        new_best = evaluated and is_better(float(summary.eval_mean_progress or 0.0), lap_time, st.best)
        before = AnnealState(st.lr_factor, st.anneal_strikes, st.rollbacks)
        verdict = judge(before, st.best, evaluated=evaluated, lap_time=lap_time, new_best=new_best)
        st.lr_factor, st.anneal_strikes, st.rollbacks = (
            verdict.state.factor, verdict.state.strikes, verdict.state.rollbacks
        )  # fmt: skip
        if verdict.rollback:
            assert st.best is not None  # judge rolls back only to a lapped best
            load_weights(self.model, checkpoint_path(self.folder, "best"))
            self._restore_reward_scale(st.best)
            self.model.set_lr_factor(st.lr_factor)
            summary.extra.update(
                {
                    "rollback_to": float(st.best["iteration"]),
                    "best_lap_time": float(best_lap_time(st.best) or 0.0),
                    "next_learning_rate": self.model.current_learning_rate(),
                }
            )
        summary.extra["lr_factor"] = st.lr_factor

    def _check_finite(self, metrics: dict[str, float | None], iteration: int) -> None:
        for name in ("policy_loss", "value_loss"):
            value = metrics.get(name)
            if value is not None and not math.isfinite(value):
                raise FloatingPointError(
                    f"The {name.replace('_', ' ')} became {value} in iteration {iteration}; "
                    "the update diverged (try a lower learning rate). The last checkpoint is kept."
                )

    # ----- evaluation ----------------------------------------------------------
    def _evaluate(self, iteration: int) -> list[EpisodeRecord]:
        """The iteration's evaluation episodes (torch on one thread: one observation at a time).

        None once the run is past its time limit or was asked to stop (a step or episode limit
        still gets its evaluation); cut (the episode in progress dropped) when the time limit
        comes during them.
        """
        if self.watch.reason in (REQUESTED, INTERRUPTED) or self.watch.past_limit():
            return []
        self._phase(EVALUATING)
        th.set_num_threads(1)
        try:
            return evaluate(
                self.model, self.eval_env, self.spec.vehicle, iteration, self.spec.eval_episodes,
                keep_going=lambda: not self.watch.past_limit(), seed=self.spec.seed,
            )  # fmt: skip
        finally:
            th.set_num_threads(self.threads)

    # ----- figures and checkpoints ---------------------------------------------
    def _summary(
        self,
        iteration: int,
        records: list[EpisodeRecord],
        eval_records: list[EpisodeRecord],
        metrics: dict[str, float | None],
        steps_before: int,
        elapsed: float,
        train_seconds: float,
    ) -> IterationSummary:
        laps = [r.lap_time for r in eval_records if r.complete and r.lap_time is not None]
        steps = self.state.steps - steps_before
        return IterationSummary(
            iteration=iteration,
            steps=self.state.steps,
            episodes=self.state.episodes,
            elapsed_seconds=self.state.elapsed,
            steps_per_second=steps / max(elapsed, 1e-9),
            train_mean_reward=mean_or_none([r.reward for r in records]),
            train_mean_progress=mean_or_none([r.progress for r in records]),
            eval_mean_reward=mean_or_none([r.reward for r in eval_records]),
            eval_mean_progress=mean_or_none([r.progress for r in eval_records]),
            eval_laps_complete=sum(r.complete for r in eval_records),
            eval_episodes=len(eval_records),
            eval_best_lap_time=min(laps) if laps else None,
            eval_mean_lap_time=mean_or_none(laps) if laps and len(laps) == len(eval_records) else None,
            policy_loss=metrics.get("policy_loss"),
            value_loss=metrics.get("value_loss"),
            entropy=metrics.get("entropy"),
            kl=metrics.get("kl"),
            learning_rate=metrics.get("learning_rate"),
            extra={"collect_seconds": train_seconds},
            by_track=figures_by_track(records),
        )

    def _checkpoint(self, iteration: int, summary: IterationSummary, evaluated: bool = True) -> None:
        """Write ``last`` (and ``best`` when better), then tell the sink.

        An iteration without a full evaluation (cut by a limit or a stop) becomes ``best`` only
        when there is no best yet.
        """
        laps_mean = summary.eval_mean_lap_time
        st = self.state
        st.iteration = iteration
        st.streak = self.watch.streak
        progress = float(summary.eval_mean_progress or 0.0)
        meta: dict[str, Any] = {
            "iteration": iteration,
            "steps": st.steps,
            "episodes": st.episodes,
            "elapsed": st.elapsed,
            "sim_time": st.sim_time,
            "streak": self.watch.streak,
            "run_key": self.spec.run_key,
            "job_steps": self.watch.steps,
            "job_episodes": self.watch.episodes,
            "job_elapsed": self.watch.elapsed,
            "eval_progress": progress,
            "eval_lap_time": laps_mean,
            "eval_laps_complete": summary.eval_laps_complete,
            "eval_episodes": summary.eval_episodes,
            "evaluated": evaluated,
            "network": self.spec.vehicle.network,
            "algorithm": self.spec.hyperparameters.algorithm,
            "towers": self.spec.hyperparameters.towers,
            "device": device_label(self.device),  # where these weights were trained (any device loads them)
            "created": time.time(),
            "lr_factor": st.lr_factor,
            "anneal_strikes": st.anneal_strikes,
            "rollbacks": st.rollbacks,
        }
        if isinstance(self.model, EpisodicPPO):
            meta["return_scale"] = self.model.return_scale.state()
        else:
            meta["reward_scale"] = self.model.reward_scale.state()
        last = save_checkpoint(self.model, checkpoint_path(self.folder, "last"), meta)
        best_path = None
        better = is_better(progress, laps_mean, st.best) if evaluated else st.best is None
        if better:
            best_path = copy_atomic(last, checkpoint_path(self.folder, "best"))
            st.best = meta
        self.sink.on_checkpoint(
            CheckpointRecord(
                iteration=iteration,
                path=str(last),
                steps=st.steps,
                episodes=st.episodes,
                eval_progress=progress,
                eval_lap_time=laps_mean,
                is_best=better,
                best_path=str(best_path) if best_path else None,
            )
        )
