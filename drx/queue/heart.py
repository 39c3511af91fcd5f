"""A job's heartbeat, kept on a background thread while the job runs."""

from __future__ import annotations

import os
import threading
import time
from typing import Any

from drx.queue import lifecycle
from drx.sim import reward_guard
from drx.train.stop import StopRequested


class Heart(threading.Thread):
    """Sends a job's heartbeats every ``min(lease / 4, 2)`` seconds and watches for stop requests.

    :param job_id: the job.
    :param worker_id: who holds it.
    :param lease_seconds: the job's lease.
    :param parent_pid: the worker process that launched this one; when it dies, :attr:`orphaned` is set.
    """

    def __init__(
        self, job_id: int, worker_id: str, lease_seconds: int, parent_pid: int | None = None
    ) -> None:
        super().__init__(name=f"drx-heartbeat-{job_id}", daemon=True)
        self.job_id = job_id
        self.worker_id = worker_id
        # Often enough that a stop request is seen within a couple of seconds.
        self.interval = max(0.2, min(2.0, lease_seconds / 4.0))
        self.parent_pid = parent_pid
        self.stop = False
        self.lost = False
        self.orphaned = False
        self._done = threading.Event()
        self.error: Any = None

    def run(self) -> None:
        """Beat until :meth:`halt`."""
        while not self._done.wait(self.interval):
            if self.parent_pid is not None and os.getppid() != self.parent_pid:
                self.orphaned = True  # the worker died: die too, so the job is requeued and resumed
                os._exit(3)
            try:
                self.beat()
            except Exception as exc:  # a database hiccup: try again next beat
                self.error = exc
                time.sleep(0.1)

    def beat(self) -> None:
        """One heartbeat: refresh the job's lease and learn whether to stop (or whether it was lost).

        Called once before the job starts (a stop requested while it was claimed is seen at once),
        then every :attr:`interval` from this thread.
        """
        beat = lifecycle.heartbeat(self.job_id, self.worker_id)
        self.stop = self.stop or beat.stop_requested
        self.lost = not beat.held
        if self.stop or self.lost:  # a reward call running for a while now ends at once
            reward_guard.interrupt(StopRequested, running_for=self.interval / 2)

    def halt(self) -> None:
        """Stop beating."""
        self._done.set()
