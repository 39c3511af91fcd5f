"""``drx train`` as a user runs it: plain progress without a terminal, ``--json``, Ctrl-C."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from drx.queue import lifecycle
from drx.registry import Model
from drx.train.checkpoint import checkpoint_path, model_folder, read_meta

MakeModel = Callable[..., Model]
DRX = [sys.executable, "-m", "drx.cli.main"]


@pytest.fixture(autouse=True)
def _one_thread(monkeypatch: pytest.MonkeyPatch) -> None:
    """Job processes use one torch thread and one rollout worker: robust on a busy test machine."""
    monkeypatch.setenv("DRX_TORCH_THREADS", "1")


def _drx(*args: str, timeout: float = 300) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [*DRX, *args], capture_output=True, text=True, timeout=timeout, env=dict(os.environ)
    )


def test_without_a_terminal_one_line_per_iteration(make_model: MakeModel) -> None:
    make_model(max_episodes=10)  # two iterations of 5 episodes
    done = _drx("train", "m")
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[0].startswith("Training m (job 1")
    iteration_lines = [line for line in lines if " done: " in line]
    assert len(iteration_lines) == 2
    assert "iteration 0 done: " in iteration_lines[0] and "eval progress" in iteration_lines[0]
    assert lines[-1].startswith("Job 1 succeeded (max_episodes)")  # a line of its own
    assert "\x1b[" not in done.stdout  # no terminal codes in a log


def test_json_prints_one_document_and_progress_on_stderr(make_model: MakeModel) -> None:
    make_model(max_episodes=5)
    done = _drx("train", "m", "--json")
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout)
    assert result["status"] == "succeeded" and result["stop_reason"] == "max_episodes"
    assert result["iterations"] == 1 and result["episodes"] == 5 and result["best"]["iteration"] == 0
    assert "iteration 0 done: " in done.stderr


@pytest.mark.parametrize("workers", ["1", "2"])
def test_ctrl_c_exits_130_and_keeps_the_checkpoint(make_model: MakeModel, workers: str) -> None:
    """Ctrl-C in a terminal reaches the whole process group, rollout workers included."""
    make_model(max_episodes=5000)
    last = checkpoint_path(model_folder("m"), "last")
    log = Path(os.environ["DRX_HOME"]) / "train.log"
    with log.open("w") as out:
        proc = subprocess.Popen(
            [*DRX, "train", "m", "--rollout-workers", workers],
            stdout=out, stderr=subprocess.STDOUT, text=True, start_new_session=True,
        )  # fmt: skip
    try:
        deadline = time.monotonic() + 240
        while not last.is_file() and time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.3)
        assert last.is_file(), log.read_text()
        os.killpg(proc.pid, signal.SIGINT)
        code = proc.wait(120)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    output = log.read_text()
    assert code == 130, output
    assert "Stopping" in output and "Job 1 stopped (requested)" in output
    assert read_meta(last)["iteration"] >= 0
    assert lifecycle.get_job(1).status == "stopped"
