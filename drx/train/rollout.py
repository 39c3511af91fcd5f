"""Rollout workers: the training episodes of one iteration sampled by K environments in K processes.

deepracer-for-cloud splits an iteration's episodes (``num_episodes_between_training``)
among ``DR_WORKERS`` simulation workers that feed one trainer (deepracer-for-cloud
``docs/multi_worker.md``; the workers run whole episodes with the current policy,
deepracer-simapp ``bundle/markov/rollout_worker.py``). There each worker advances its own
start by ``ROUND_ROBIN_ADVANCE_DIST`` after each of its episodes (deepracer-simapp
``bundle/markov/agent_ctrl/rollout_agent_ctrl.py``, ``finish_episode``), which is why that
page asks for ``episodes / workers x advance = 1``; drx instead numbers the episodes across
workers, so their starts are exactly one worker's whatever K is.

Inside one job, :class:`RolloutWorkers` holds K training environments, each in its own
process (like SB3's ``SubprocVecEnv``, but without auto-reset: the trainer says which
episode each environment starts next, so DeepRacer's round robin of starts, episode
``g`` at ``g x 5%`` of the lap, holds across workers), and
:meth:`drx.train.ppo.EpisodicPPO.collect_episodes_parallel` steps the environments that
have an episode in progress together, with one batched policy call per step.

Episodes end out of order; the collector hands them to the trainer in episode order, so the
trace, the episode rows and the counters are those one worker would write.

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
from collections.abc import Callable, Sequence
from multiprocessing.connection import Connection
from typing import Any

import cloudpickle
import gymnasium as gym
import numpy as np

from drx.errors import DrxError
from drx.sim.env import ROUND_ROBIN_STEP
from drx.train.trace import closest_waypoint

START_METHOD = "forkserver"
# Imported once by the fork server, so each worker forks with them loaded (torch is not among
# them: a worker never needs it).
PRELOAD = ["drx.sim.env", "drx.sim.registration", "drx.train.trace"]


class _Pickled:
    """A callable carried to a worker by cloudpickle (closures included), as SB3's wrapper does."""

    def __init__(self, value: Any) -> None:
        self.value = value

    def __getstate__(self) -> bytes:
        return cloudpickle.dumps(self.value)

    def __setstate__(self, state: bytes) -> None:
        self.value = pickle.loads(state)


# Cores per rollout worker by default. The trainer's process needs cores too (its policy calls
# while workers step, then the update on every thread it has), so a job gets one worker per two
# cores: on 2 cores, 1. Measured with benchmarks/train_throughput.py --rollout-workers 1 2 4 on
# 2 cores at load 3-4 (docs/TRAINING.md): 2 workers vs 1 gave 0.98x for shallow (its update,
# ~80% of the time, already uses both cores) and 0.59x for compact (a step's round trip to a
# worker costs more than the step it saves).
CORES_PER_WORKER = 2
MAX_DEFAULT_WORKERS = 8  # past this one trainer process feeding them is the bottleneck (estimate)


def default_rollout_workers(cores: int) -> int:
    """Rollout workers for a job that may use ``cores`` cores: one per two cores, 1 to 8."""
    return max(1, min(MAX_DEFAULT_WORKERS, int(cores) // CORES_PER_WORKER))


def start_fraction(episode: int) -> float:
    """Where training episode ``episode`` (the model's running number) starts, as a fraction of the lap
    (the environment's own round robin, ``drx.sim.env`` ``reset``, for one worker)."""
    return (episode * ROUND_ROBIN_STEP) % 1.0


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


def _worker(remote: Connection, parent: Connection, factory: _Pickled, seed: int | None) -> None:
    """A worker process: build the training env, then serve ``reset``/``step``/``close``."""
    parent.close()
    # Ctrl-C in a terminal reaches the whole process group: the trainer handles it (keeping a
    # checkpoint) and then closes the workers, so a worker must not die of it first.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    try:
        import cv2

        cv2.setNumThreads(1)  # one env per process: OpenCV's own threads only compete with the others
    except ImportError:  # pragma: no cover - OpenCV is a dependency of the camera
        pass
    env: gym.Env | None = None
    seeded = False
    try:
        env = factory.value("training")
        while True:
            cmd, data = remote.recv()
            if cmd == "step":
                obs, reward, terminated, truncated, info = env.step(data)
                remote.send(("ok", (obs, float(reward), bool(terminated), bool(truncated), slim_info(info))))
            elif cmd == "reset":
                first_seed = None if seeded or seed is None else seed
                seeded = True
                obs, info = env.reset(seed=first_seed, options=data)
                remote.send(("ok", (obs, slim_info(info))))
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
    """K training environments, one per process.

    :param env_factory: builds an environment for a mode (called with ``"training"`` in each
        worker; it must survive cloudpickle).
    :param count: the number of workers (at least 2; one worker runs in the trainer's process).
    :param seed: worker ``k`` seeds its environment with ``seed + k`` (``None``: unseeded).
    """

    def __init__(self, env_factory: Callable[[str], gym.Env], count: int, seed: int | None = None) -> None:
        if count < 2:
            raise DrxError(f"RolloutWorkers needs 2 or more workers, got {count}; 1 runs in the trainer.")
        ctx = mp.get_context(START_METHOD)
        ctx.set_forkserver_preload(PRELOAD)
        self.count = int(count)
        self.remotes: list[Connection] = []
        self.processes: list[Any] = []
        wrapped = _Pickled(env_factory)
        for k in range(self.count):
            remote, work_remote = ctx.Pipe()
            worker_seed = None if seed is None else int(seed) + k
            process = ctx.Process(
                target=_worker, args=(work_remote, remote, wrapped, worker_seed), daemon=True,
                name=f"drx-rollout-{k}",
            )  # fmt: skip
            process.start()
            work_remote.close()
            self.remotes.append(remote)
            self.processes.append(process)
        self._finalizer = weakref.finalize(self, _shutdown, self.remotes, self.processes)

    def _receive(self, k: int) -> Any:
        try:
            status, payload = self.remotes[k].recv()
        except (EOFError, ConnectionError):
            raise DrxError(
                f"Rollout worker {k} ended unexpectedly (exit code {self.processes[k].exitcode}); "
                "train with --rollout-workers 1 to see the error in this process."
            ) from None
        if status == "error":
            raise payload
        return payload

    def reset(self, requests: Sequence[tuple[int, dict[str, Any]]]) -> list[tuple[Any, dict[str, Any]]]:
        """Start an episode in each listed worker: ``[(k, reset options)]`` -> ``[(obs, info)]``."""
        for k, options in requests:
            self.remotes[k].send(("reset", options))
        return [self._receive(k) for k, _ in requests]

    def step(
        self, requests: Sequence[tuple[int, Any]]
    ) -> list[tuple[Any, float, bool, bool, dict[str, Any]]]:
        """Step each listed worker: ``[(k, action)]`` -> ``[(obs, reward, terminated, truncated, info)]``."""
        for k, action in requests:
            self.remotes[k].send(("step", action))
        return [self._receive(k) for k, _ in requests]

    def close(self) -> None:
        """Stop the worker processes."""
        self._finalizer()


def stack_observations(observations: Sequence[Any]) -> Any:
    """A batch of single observations (arrays or dicts of arrays) with a leading axis."""
    first = observations[0]
    if isinstance(first, dict):
        return {key: np.stack([o[key] for o in observations]) for key in first}
    return np.stack(observations)
