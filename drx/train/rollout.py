"""Rollout workers: the training episodes of one iteration sampled by K processes, each with its own policy.

deepracer-for-cloud splits an iteration's episodes (``num_episodes_between_training``)
among ``DR_WORKERS`` simulation workers that feed one trainer (deepracer-for-cloud
``docs/multi_worker.md``). Each of those workers runs whole episodes with its own copy of
the current policy and hands the trainer whole episodes; between iterations it loads the
trainer's new checkpoint (deepracer-simapp ``bundle/markov/rollout_worker.py``: the worker
acts for its episodes, then waits for and restores the next policy). There each worker
advances its own start by ``ROUND_ROBIN_ADVANCE_DIST`` after each of its episodes
(deepracer-simapp ``bundle/markov/agent_ctrl/rollout_agent_ctrl.py``, ``finish_episode``),
which is why that page asks for ``episodes / workers x advance = 1``; drx instead numbers
the episodes across workers, so their starts are exactly one worker's whatever K is.

drx does the same inside one job: :class:`RolloutWorkers` holds K training environments,
each in its own process with a copy of the policy (torch on one thread there). At the start
of an iteration the trainer ships the policy's weights once (:meth:`RolloutWorkers.set_policy`);
then it asks for episode ``g`` (at ``g x 5%`` of the lap, DeepRacer's round robin; a model's own
starts, tracks and directions are its env's, :class:`drx.sim.schedule.ScheduledEnv`, which each
worker builds from the job's env factory and which builds the track's env the episode needs) on
whichever worker is free next, and the worker drives the whole episode without talking to
the trainer and sends it back in one message (:class:`EpisodeSteps`: observations, actions,
values, log-probabilities, rewards, infos). SB3's ``SubprocVecEnv`` would instead cross a
pipe on every step with the policy in the trainer's process, which on 2 cores made two
workers no faster than one (docs/TRAINING.md).

With a seed, episode ``g`` seeds its environment and its action sampling from ``(seed, g)``
(:func:`episode_seeds`), so a run is reproducible and the same whatever K and whichever
worker drives which episode. Episodes end out of order; the trainer hands them on in
episode order (:meth:`drx.train.ppo.EpisodicPPO.collect_episodes_parallel`), so the trace,
the episode rows and the counters are those one worker would write.

Workers run their policy on their CPU whatever the job's device (:mod:`drx.train.device`): each
builds its copy there, and :meth:`RolloutWorkers.set_policy` copies the weights off the device;
with one worker, :class:`EpisodeDriver` drives the trainer's own policy on the job's device.

The processes start with ``forkserver`` (as SB3's ``SubprocVecEnv`` does): the trainer's
process has torch's and OpenCV's thread pools running, which a plain ``fork`` would copy
in a broken state. A step's ``info`` travels back without the track's waypoint list (the
trace's ``closest_waypoint`` is computed in the worker), which would otherwise cost more to
pickle than the step.
"""

from __future__ import annotations

import contextlib
import multiprocessing as mp
import os
import pickle
import signal
import weakref
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from typing import Any

import cloudpickle
import gymnasium as gym
import numpy as np

from drx.errors import DrxError
from drx.sim.env import ROUND_ROBIN_STEP
from drx.train.trace import closest_waypoint

START_METHOD = "forkserver"
# Imported once by the fork server, so each worker forks with them loaded (the policy's
# network brings torch and SB3).
PRELOAD = ["drx.sim.env", "drx.sim.registration", "drx.train.trace", "drx.train.networks"]
POLL_SECONDS = 0.05  # how often the trainer asks ``keep_going`` while the workers drive


class _Pickled:
    """A value carried to a worker by cloudpickle (closures included), as SB3's wrapper does."""

    def __init__(self, value: Any) -> None:
        self.value = value

    def __getstate__(self) -> bytes:
        return cloudpickle.dumps(self.value)

    def __setstate__(self, state: bytes) -> None:
        self.value = pickle.loads(state)


# Cores per rollout worker by default. Measured with benchmarks/train_throughput.py
# --rollout-workers 1 2 4 on 2 cores at load 6-7 (docs/TRAINING.md): 2 workers gave compact 1.3x
# and shallow ~1.0x (its update, ~75-80% of an iteration, already uses both cores), for a
# start-up of 3-12 s per job; on 2 cores one worker stays the default (short runs, like the
# README's, would spend the gain on the start-up), and the trainer's update keeps a core's worth.
CORES_PER_WORKER = 2
MAX_DEFAULT_WORKERS = 8  # past this one trainer process feeding them is the bottleneck (estimate)


def default_rollout_workers(cores: int) -> int:
    """Rollout workers for a job that may use ``cores`` cores: one per two cores, 1 to 8."""
    return max(1, min(MAX_DEFAULT_WORKERS, int(cores) // CORES_PER_WORKER))


def start_fraction(episode: int) -> float:
    """Where training episode ``episode`` (the model's running number) starts, as a fraction of the lap,
    with DeepRacer's default round robin, as ``drx.sim.env`` ``reset`` runs it without a ``start``
    option (a model's own starts and tracks: :meth:`drx.settings.episodes.EpisodeSettings.start`,
    which its training env, :class:`drx.sim.schedule.ScheduledEnv`, follows)."""
    return (episode * ROUND_ROBIN_STEP) % 1.0


def episode_seeds(seed: int, episode: int) -> tuple[int, int]:
    """The environment's and the action sampling's seeds for episode ``episode`` of a run seeded ``seed``."""
    env_seed, torch_seed = np.random.SeedSequence([int(seed), int(episode)]).generate_state(2)
    return int(env_seed), int(torch_seed)


def slim_info(info: dict[str, Any]) -> dict[str, Any]:
    """``info`` without the waypoint list: the trace's ``closest_waypoint`` is resolved here."""
    params = info.get("params")
    if not params or "waypoints" not in params:
        return info
    params = dict(params)
    nearest = closest_waypoint(params)
    params["closest_waypoints"] = [nearest, nearest]  # closest_waypoint() of this gives ``nearest``
    del params["waypoints"]
    return {**info, "params": params}


@dataclass
class EpisodeSteps:
    """One whole episode as a worker drove it, one row per step.

    :param observations: the observation each step acted on, channel-first as the policy
        reads it, shape ``(n, ...)`` (a dict of such arrays for camera + lidar).
    :param actions: the policy's actions ``(n, ...)`` (unclipped, as the buffer keeps them).
    :param env_actions: the actions the environment got (continuous ones clipped to the space).
    :param rewards: rewards ``(n,)``; a time-up ending adds ``gamma x value`` of the final
        observation to the last, as SB3's ``OnPolicyAlgorithm.collect_rollouts`` does.
    :param values: the value estimates ``(n,)``.
    :param log_probs: the actions' log-probabilities ``(n,)``.
    :param infos: each step's ``info`` (:func:`slim_info`).
    """

    observations: Any
    actions: np.ndarray
    env_actions: np.ndarray
    rewards: np.ndarray
    values: np.ndarray
    log_probs: np.ndarray
    infos: list[dict[str, Any]]

    def __len__(self) -> int:
        return len(self.rewards)

    def observation(self, i: int) -> Any:
        """Step ``i``'s observation with a leading axis of one (what a rollout buffer adds)."""
        if isinstance(self.observations, dict):
            return {key: value[i : i + 1] for key, value in self.observations.items()}
        return self.observations[i : i + 1]


class _Aborted(Exception):
    """The trainer asked a worker to drop the episode it is driving."""


class EpisodeDriver:
    """Drives whole training episodes with a policy: in each rollout worker (its own copy) and,
    for one worker, in the trainer's process, so that both drive an episode alike.

    :param policy: an SB3 actor-critic policy (put in evaluation mode).
    :param gamma: what a time-up ending's final value is multiplied by before it joins the last
        reward: the discount, times the value head's return scale
        (:attr:`drx.train.ppo.EpisodicPPO.bootstrap_factor`).
    """

    def __init__(self, policy: Any, gamma: float) -> None:
        from gymnasium import spaces
        from stable_baselines3.common.preprocessing import is_image_space, maybe_transpose

        self.policy = policy
        self._transpose = maybe_transpose  # bound once: _channel_first runs every step
        self.gamma = float(gamma)
        # which observations are images to put channel-first, worked out once (not every step)
        space = policy.observation_space
        self._image_space: dict[str | None, Any] = (
            {key: sub for key, sub in space.spaces.items() if is_image_space(sub)}
            if isinstance(space, spaces.Dict)
            else ({None: space} if is_image_space(space) else {})
        )

    @classmethod
    def build(cls, policy_class: type, constructor: dict[str, Any], gamma: float) -> EpisodeDriver:
        """A driver with a new policy, as SB3's ``BasePolicy.load`` rebuilds one (weights to load)."""
        return cls(policy_class(**constructor), gamma)

    def load(self, weights: dict[str, np.ndarray]) -> None:
        """Take the trainer's current weights."""
        import torch as th

        self.policy.load_state_dict({k: th.from_numpy(v) for k, v in weights.items()})

    def _channel_first(self, obs: Any) -> Any:
        """``obs`` as the policy reads it (images channel-first), without a batch axis."""
        images, transpose = self._image_space, self._transpose
        if isinstance(obs, dict):
            return {
                key: transpose(np.asarray(value), images[key]) if key in images else value
                for key, value in obs.items()
            }
        return transpose(np.asarray(obs), images[None]) if None in images else np.asarray(obs)

    def steps(
        self, env: gym.Env, episode: int, seed: int | None
    ) -> Iterator[tuple[Any, np.ndarray, np.ndarray, float, float, float, dict[str, Any], bool]]:
        """Drive training episode ``episode`` (the model's running number) from its round-robin start
        (on its track and in its direction: the env's reset option ``episode``).

        Yields each step as it happens: ``(observation acted on, action, env action, reward,
        value, log-probability, info, done)``; a time-up ending adds ``gamma x value`` of the
        final observation to the last reward (as SB3's ``OnPolicyAlgorithm.collect_rollouts``
        does). With a ``seed`` the environment and the action sampling are seeded from
        ``(seed, episode)`` (:func:`episode_seeds`), which sets torch's global generator.
        """
        import torch as th
        from gymnasium import spaces
        from stable_baselines3.common.utils import obs_as_tensor

        policy = self.policy
        policy.set_training_mode(False)
        env_seed = None
        if seed is not None:
            env_seed, torch_seed = episode_seeds(seed, episode)
            th.manual_seed(torch_seed)
        # The env knows where (and, for a model with several tracks or alternating directions, on
        # which track and which way) its episode ``episode`` starts: the simulator's own round robin,
        # or the model's schedule (drx.sim.schedule.ScheduledEnv).
        obs, _info = env.reset(seed=env_seed, options={"episode": int(episode)})
        box = isinstance(policy.action_space, spaces.Box)
        done = False
        while not done:
            row = self._channel_first(obs)
            batch = {k: v[None] for k, v in row.items()} if isinstance(row, dict) else row[None]
            with th.no_grad():
                action, value, log_prob = policy(obs_as_tensor(batch, policy.device))  # type: ignore[arg-type]
            action_np = action.cpu().numpy()[0]  # the trainer's own policy may sit on a GPU
            env_action = (
                np.clip(action_np, policy.action_space.low, policy.action_space.high) if box else action_np
            )
            obs, reward, terminated, truncated, info = env.step(env_action)
            reward = float(reward)
            if truncated and not terminated:  # bootstrap a time-up ending, as SB3 does
                with th.no_grad():
                    final = policy.obs_to_tensor(self._channel_first(obs))[0]
                    reward += self.gamma * float(policy.predict_values(final)[0])  # type: ignore[arg-type]
            done = bool(terminated or truncated)
            yield row, action_np, env_action, reward, float(value[0]), float(log_prob[0]), info, done

    def drive(
        self, env: gym.Env, episode: int, seed: int | None, aborted: Callable[[], bool]
    ) -> EpisodeSteps:
        """The whole episode :meth:`steps` drives, in one message; :class:`_Aborted` when ``aborted()``."""
        rows: list[Any] = []
        actions, env_actions, rewards, values, log_probs, infos = [], [], [], [], [], []
        for row, action, env_action, reward, value, log_prob, info, _done in self.steps(env, episode, seed):
            rows.append(row)
            actions.append(action)
            env_actions.append(env_action)
            rewards.append(reward)
            values.append(value)
            log_probs.append(log_prob)
            infos.append(slim_info(info))
            if aborted():
                raise _Aborted
        observations = (
            {key: np.stack([r[key] for r in rows]) for key in rows[0]}
            if isinstance(rows[0], dict)
            else np.stack(rows)
        )
        return EpisodeSteps(
            observations=observations,
            actions=np.stack(actions),
            env_actions=np.stack(env_actions),
            rewards=np.asarray(rewards, dtype=np.float64),
            values=np.asarray(values, dtype=np.float32),
            log_probs=np.asarray(log_probs, dtype=np.float32),
            infos=infos,
        )


def _worker(remote: Connection, parent: Connection, factory: _Pickled, seed: int | None) -> None:
    """A worker process: build the training env, then serve the trainer's commands.

    ``policy`` (build the policy), ``weights`` (load them), ``episode`` (drive one, send it
    back whole), ``abort``, ``close``.

    Every command gets exactly one reply; an ``abort`` that finds an episode in progress ends it
    (its reply is ``None``) before the ``abort`` itself is answered.
    """
    parent.close()
    # Ctrl-C in a terminal reaches the whole process group: the trainer handles it (keeping a
    # checkpoint) and then closes the workers, so a worker must not die of it first.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    import torch as th

    th.set_num_threads(1)  # one worker per core: more threads only compete with the other workers
    if seed is None:  # forked workers share torch's default seed: give each its own stream
        th.manual_seed(int.from_bytes(os.urandom(8), "little") >> 1)
    try:
        import cv2

        cv2.setNumThreads(1)
    except ImportError:  # pragma: no cover - OpenCV is a dependency of the camera
        pass
    env: gym.Env | None = None
    driver: EpisodeDriver | None = None
    try:
        env = factory.value("training")
        while True:
            cmd, data = remote.recv()
            if cmd == "episode":
                if driver is None:
                    raise DrxError("Rollout worker got an episode before a policy.")
                try:
                    remote.send(("ok", driver.drive(env, int(data), seed, remote.poll)))
                except _Aborted:
                    remote.send(("ok", None))
            elif cmd == "policy":
                policy_class, constructor, gamma = data.value
                driver = EpisodeDriver.build(policy_class, constructor, gamma)
                remote.send(("ok", None))
            elif cmd == "weights":
                if driver is None:
                    raise DrxError("Rollout worker got weights before a policy.")
                weights, driver.gamma = data
                driver.load(weights)
                remote.send(("ok", None))
            elif cmd == "abort":
                remote.send(("aborted", None))
            elif cmd == "close":
                break
            else:
                remote.send(("error", DrxError(f"Rollout worker got an unknown command {cmd!r}.")))
    except BaseException as exc:  # noqa: BLE001 - every failure goes back to the trainer, which raises it
        try:
            pickle.dumps(exc)
            remote.send(("error", exc))
        except Exception:  # an exception that cannot travel: its sentence does
            remote.send(("error", RuntimeError(f"{type(exc).__name__}: {exc}")))
    finally:
        if env is not None:
            env.close()
        remote.close()


def _shutdown(remotes: list[Connection], processes: list[Any]) -> None:
    for remote in remotes:
        with contextlib.suppress(BrokenPipeError, OSError):
            remote.send(("close", None))
    for process in processes:
        process.join(timeout=5)
        if process.is_alive():
            process.terminate()
            process.join(timeout=5)
    for remote in remotes:
        remote.close()


class RolloutWorkers:
    """K training environments, one per process, each driving whole episodes with its copy of the policy.

    :param env_factory: builds an environment for a mode (called with ``"training"`` in each
        worker; it must survive cloudpickle).
    :param count: the number of workers (at least 2; one worker runs in the trainer's process).
    :param seed: episode ``g`` is seeded from ``(seed, g)`` (:func:`episode_seeds`; ``None``: unseeded).
    """

    def __init__(self, env_factory: Callable[[str], gym.Env], count: int, seed: int | None = None) -> None:
        if count < 2:
            raise DrxError(f"RolloutWorkers needs 2 or more workers, got {count}; 1 runs in the trainer.")
        ctx: Any = mp.get_context(START_METHOD)  # typeshed's BaseContext lacks Process
        ctx.set_forkserver_preload(PRELOAD)
        self.count = int(count)
        self.seed = None if seed is None else int(seed)
        self.remotes: list[Connection] = []
        self.processes: list[Any] = []
        self.busy: dict[int, int] = {}  # worker -> the episode it is driving
        self._policy_built = False
        wrapped = _Pickled(env_factory)
        for k in range(self.count):
            remote, work_remote = ctx.Pipe()
            process = ctx.Process(
                target=_worker, args=(work_remote, remote, wrapped, self.seed), daemon=True,
                name=f"drx-rollout-{k}",
            )  # fmt: skip
            process.start()
            work_remote.close()
            self.remotes.append(remote)
            self.processes.append(process)
        self._finalizer = weakref.finalize(self, _shutdown, self.remotes, self.processes)

    def _receive(self, k: int) -> tuple[str, Any]:
        try:
            status, payload = self.remotes[k].recv()
        except (EOFError, ConnectionError):
            raise DrxError(
                f"Rollout worker {k} ended unexpectedly (exit code {self.processes[k].exitcode}); "
                "train with one rollout worker (rollout_workers 1) to see the error in this process."
            ) from None
        if status == "error":
            raise payload
        return status, payload

    def _ask_all(self, cmd: str, data: Any) -> None:
        for remote in self.remotes:
            remote.send((cmd, data))
        for k in range(self.count):
            self._receive(k)

    def set_policy(self, policy: Any, gamma: float) -> None:
        """Give every worker ``policy``'s current weights (the first call also its class and shape).

        :param policy: an SB3 policy (rebuilt in the workers from ``_get_constructor_parameters``,
            as SB3's ``BasePolicy.load`` rebuilds one).
        :param gamma: what a time-up ending's final value is multiplied by (the discount, times the
            value head's return scale: :attr:`drx.train.ppo.EpisodicPPO.bootstrap_factor`); sent
            with every set of weights, as the scale changes between iterations.
        """
        assert not self.busy, "set_policy() between iterations only"
        if not self._policy_built:
            self._ask_all("policy", _Pickled((type(policy), policy._get_constructor_parameters(), gamma)))
            self._policy_built = True
        weights = {k: v.detach().cpu().numpy() for k, v in policy.state_dict().items()}
        self._ask_all("weights", (weights, float(gamma)))

    def start(self, k: int, episode: int) -> None:
        """Have worker ``k`` drive training episode ``episode`` (the model's running number),
        starting where the round robin puts it."""
        self.remotes[k].send(("episode", int(episode)))
        self.busy[k] = episode

    def finished(self, timeout: float | None = POLL_SECONDS) -> list[tuple[int, int, EpisodeSteps]]:
        """Episodes that ended within ``timeout`` seconds: ``[(worker, episode, steps)]``."""
        ready = wait([self.remotes[k] for k in self.busy], timeout)
        done = []
        for k in sorted(self.busy):
            if self.remotes[k] in ready:
                _status, steps = self._receive(k)
                done.append((k, self.busy.pop(k), steps))
        return done

    def abort(self) -> None:
        """Drop the episodes in progress (their steps are lost), leaving every worker idle."""
        busy, self.busy = sorted(self.busy), {}
        for k in busy:
            self.remotes[k].send(("abort", None))
        for k in busy:
            while self._receive(k)[0] != "aborted":
                pass

    def close(self) -> None:
        """Stop the worker processes."""
        self._finalizer()
