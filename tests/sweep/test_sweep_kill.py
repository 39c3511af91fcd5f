"""Killing a worker (SIGKILL) mid-trial loses at most the iteration in progress: the next worker
resumes the trial from its last checkpoint and the trial reports every iteration exactly once."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import optuna
import pytest
from sqlalchemy import select

from drx.queue import lifecycle
from drx.registry import IterationMetric, session_scope
from drx.services.models import get_model
from drx.sweep.service import create_sweep, load_sweep

from .conftest import MakeModel

DRX = [sys.executable, "-m", "drx.cli.main"]


def _worker(*args: str) -> subprocess.Popen[bytes]:
    log = Path(os.environ["DRX_HOME"]) / f"worker-{time.monotonic_ns()}.log"
    log.parent.mkdir(parents=True, exist_ok=True)
    with log.open("wb") as out:
        return subprocess.Popen([*DRX, "worker", *args], stdout=out, stderr=subprocess.STDOUT)


@pytest.mark.slow
def test_killed_worker_loses_at_most_the_trials_last_iteration(
    make_source: MakeModel, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("DRX_TORCH_THREADS", "1")
    monkeypatch.setenv("DRX_JOB_LEASE_SECONDS", "2")
    make_source(max_episodes=20)  # 4 iterations
    create_sweep("s", "base", 1, ["lr=1e-5:1e-3:log"], pruner="none")
    _, study = load_sweep("s")
    job_id = study.trials[0].user_attrs["job"]

    def reported() -> int:
        return len(optuna.load_study(study_name="s", storage=study._storage).trials[0].intermediate_values)

    first = _worker()
    try:
        deadline = time.monotonic() + 300
        while reported() < 1 and time.monotonic() < deadline:
            time.sleep(0.3)
    finally:
        first.send_signal(signal.SIGKILL)
        first.wait(10)
    assert reported() >= 1 and lifecycle.get_job(job_id).status == "running"
    second = _worker("--exit-when-idle")
    assert second.wait(400) == 0

    trial = optuna.load_study(study_name="s", storage=study._storage).trials[0]
    assert trial.state == optuna.trial.TrialState.COMPLETE
    assert sorted(trial.intermediate_values) == [0, 1, 2, 3]
    job = lifecycle.get_job(job_id)
    assert job.status == "succeeded" and job.attempts == 2
    with session_scope() as s:
        rows = s.execute(
            select(IterationMetric.iteration, IterationMetric.eval_mean_progress).where(
                IterationMetric.model_id == get_model("s-0").id
            )
        ).all()
    assert sorted(i for i, _ in rows) == [0, 1, 2, 3]  # none lost, none twice
    assert {i: v for i, v in rows} == pytest.approx(trial.intermediate_values)
