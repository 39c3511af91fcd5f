"""A job as ``drx watch`` sees one, without training: a real env driven by a fixed policy.

The model and its job are real registry rows (the job claimed as a worker claims it), the car is
the simulator's, stepped through :class:`~drx.watch.live.LivePoseWriter` as a job's env is, and
iterations end when the test says so, written by the queue's own
:class:`~drx.queue.registry_sink.RegistrySink`.
"""

from __future__ import annotations

import threading
import time

import numpy as np

from drx.queue import lifecycle
from drx.queue.registry_sink import RegistrySink
from drx.services.models import create_model, model_artifacts_dir
from drx.sim.env import DeepRacerEnv
from drx.train.records import IterationSummary
from drx.watch.live import LivePoseWriter


class SimulatedJob:
    """Model ``name`` on the oval with a running training job; :meth:`drive` starts the car.

    :param name: the model's name.
    """

    def __init__(self, name: str) -> None:
        self.model = create_model(name, track="oval", network="compact", stop_conditions={"max_minutes": 5})
        self.job = lifecycle.enqueue_training(name)
        self.worker = lifecycle.new_worker_id()
        assert lifecycle.claim(self.job.id, self.worker)
        self.folder = model_artifacts_dir(name)
        self.sink = RegistrySink(self.model.id, self.job.id)
        self.iterations = 0
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.steps = 0

    def drive(self, mode: str = "training", steps_per_second: float = 60.0) -> None:
        """Drive in a thread: straight ahead at 1 m/s until the car leaves the track, then again."""
        env = LivePoseWriter(DeepRacerEnv(track="oval", mode=mode), self.folder, mode)

        def run() -> None:
            env.reset(seed=0)
            action = 5  # the default car's 0°, 1 m/s
            while not self._stop.is_set():
                _, _, terminated, truncated, _ = env.step(np.int64(action))
                self.steps += 1
                if terminated or truncated:
                    env.reset()
                time.sleep(1.0 / steps_per_second)
            env.close()

        self._thread = threading.Thread(target=run, daemon=True)
        self._thread.start()

    def end_iteration(self) -> None:
        """Write one iteration's metrics row, as the trainer's sink does when an iteration ends."""
        k = self.iterations
        self.sink.on_iteration(
            IterationSummary(
                iteration=k, steps=100 * (k + 1), episodes=5 * (k + 1), elapsed_seconds=10.0 * (k + 1),
                steps_per_second=120.0, train_mean_reward=20.0 + 7 * k, train_mean_progress=10.0 + 9 * k,
                eval_mean_reward=15.0 + 6 * k, eval_mean_progress=8.0 + 11 * k,
            ),
            [],
        )  # fmt: skip
        self.iterations += 1

    def stop(self) -> None:
        """Stop the car (its pose file goes with its env)."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=10)
