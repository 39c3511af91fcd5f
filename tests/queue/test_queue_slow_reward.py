"""A slow reward function does not hold up a stop request or a worker's shutdown; a time-out fails the job."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from drx.queue import lifecycle
from drx.queue.dispatch import run_job
from drx.registry import Model

MakeModel = Callable[..., Model]
DRX = [sys.executable, "-m", "drx.cli.main"]


def _slow_reward(tmp_path: Path, mark: Path) -> Path:
    """A reward whose 20th call marks a file and then computes for ten minutes."""
    path = tmp_path / "slow_reward.py"
    path.write_text(
        "import pathlib, time\nCALLS = [0]\n\n\ndef reward_function(params):\n    CALLS[0] += 1\n"
        f"    if CALLS[0] == 20:\n        pathlib.Path({str(mark)!r}).touch()\n"
        "        t0 = time.monotonic()\n        while time.monotonic() - t0 < 600:\n            pass\n"
        "    return 1.0\n"
    )
    return path


def _wait(predicate: Callable[[], bool], timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return
        time.sleep(0.1)
    raise AssertionError(f"timed out waiting for {what}")


@pytest.fixture(autouse=True)
def _env(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("DRX_TORCH_THREADS", "1")
    monkeypatch.setenv("DRX_REWARD_TIME_LIMIT", "900")  # the sleep stays under the limit
    monkeypatch.setenv("DRX_JOB_LEASE_SECONDS", "4")  # heartbeats every second


def _worker(home: Path) -> subprocess.Popen[bytes]:
    log = home / "worker.log"
    log.parent.mkdir(parents=True, exist_ok=True)
    with log.open("wb") as out:
        return subprocess.Popen([*DRX, "worker"], stdout=out, stderr=subprocess.STDOUT)


@pytest.mark.parametrize("how", ["stop", "sigterm"])
def test_stop_and_shutdown_take_effect_during_a_slow_reward(
    make_model: MakeModel, tmp_path: Path, how: str
) -> None:
    mark = tmp_path / "sleeping"
    make_model(reward=_slow_reward(tmp_path, mark), max_episodes=1000)
    job = lifecycle.enqueue_training("m", {"eval_episodes": 1})
    worker = _worker(Path(os.environ["DRX_HOME"]))
    try:
        _wait(mark.is_file, 120, "the reward to start sleeping")
        t0 = time.monotonic()
        if how == "stop":
            assert lifecycle.request_stop(job.id) == "running"
            _wait(lambda: lifecycle.get_job(job.id).status != "running", 20, "the job to stop")
        else:
            worker.send_signal(signal.SIGTERM)
            worker.wait(30)
        waited = time.monotonic() - t0
    finally:
        if worker.poll() is None:
            worker.send_signal(signal.SIGTERM)
            worker.wait(30)
    done = lifecycle.get_job(job.id)
    if how == "stop":
        assert (done.status, done.stop_reason) == ("stopped", "requested")
    else:  # handed back to the queue, not failed by the reward wrapper
        assert done.status == "queued" and done.error is None
    assert waited < 10.0  # heartbeats every second; the sleep had ten minutes to go


def test_a_reward_over_the_time_limit_fails_the_job_naming_the_line(
    make_model: MakeModel, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("DRX_REWARD_TIME_LIMIT", "0.3")
    make_model(reward=_slow_reward(tmp_path, tmp_path / "sleeping"), max_episodes=1000)
    job = lifecycle.enqueue_training("m", {"eval_episodes": 1})
    t0 = time.monotonic()
    outcome = run_job(job.id)
    assert time.monotonic() - t0 < 120
    assert outcome.status == "failed"
    error = lifecycle.get_job(job.id).error or ""
    # the busy loop's lines: 10 (while) or 11 (pass)
    expected = r"reward_function.py, line 1[01]: reward_function ran longer than 0.3 s \(the time limit\)"
    assert re.search(expected, error), error
