"""The figure: a sweep of 6 trials run by 2 ``drx worker`` processes ends with 6 distinct trials and
models, and the best trial's hyperparameters are the ones its model row holds."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from drx.queue import lifecycle
from drx.services.models import get_model
from drx.settings.hyperparameters import Hyperparameters
from drx.sweep.service import create_sweep, load_sweep
from tests.cli.helpers import ok_json

from .conftest import MakeModel

DRX = [sys.executable, "-m", "drx.cli.main"]


def _worker(home: Path, n: int) -> subprocess.Popen[bytes]:
    log = home / f"worker-{n}.log"
    log.parent.mkdir(parents=True, exist_ok=True)
    with log.open("wb") as out:
        return subprocess.Popen([*DRX, "worker", "--exit-when-idle"], stdout=out, stderr=subprocess.STDOUT)


@pytest.mark.parametrize(
    "iterations", [1, pytest.param(3, marks=pytest.mark.slow, id="3-iterations-slow")], ids=str
)
def test_six_trials_two_workers(
    make_source: MakeModel, monkeypatch: pytest.MonkeyPatch, iterations: int
) -> None:
    monkeypatch.setenv("DRX_TORCH_THREADS", "1")
    make_source(max_episodes=5 * iterations)  # iterations of 5 episodes per trial
    create_sweep(
        "s",
        "base",
        6,
        ["lr=1e-8:1e-3:log", "epochs=3,10", "batch-size=32,64"],
        startup_trials=1,
        warmup_iterations=0,
    )
    home = Path(os.environ["DRX_HOME"])
    started = time.monotonic()
    workers = [_worker(home, n) for n in range(2)]
    try:
        for w in workers:
            assert w.wait(600) == 0
    finally:
        for w in workers:
            if w.poll() is None:
                w.kill()
    print(f"6 trials, 2 workers: {time.monotonic() - started:.0f} s")

    data = ok_json("sweep", "show", "s")
    trials = data["trials"]
    assert len(trials) == 6 and sorted(t["number"] for t in trials) == list(range(6))
    assert len({t["model"] for t in trials}) == 6
    assert {t["state"] for t in trials} <= {"complete", "pruned"}, trials
    assert all(1 <= t["iterations"] <= iterations for t in trials)
    workers_used = {lifecycle.get_job(t["job"]).attempt_log[-1]["worker"] for t in trials}
    assert len(workers_used) == 2  # both workers ran trials
    for t in trials:
        hp = Hyperparameters.from_dict(get_model(t["model"]).hyperparameters)
        assert (hp.learning_rate, hp.num_epochs, hp.batch_size) == pytest.approx(
            (t["params"]["lr"], t["params"]["epochs"], t["params"]["batch-size"])
        )
    best = data["best"]
    assert best is not None and best["number"] == trials[0]["number"]  # ranked first
    _, study = load_sweep("s")
    assert study.best_trial.number == best["number"]
    row = get_model(best["model"])
    assert row.hyperparameters["learning_rate"] == pytest.approx(study.best_trial.params["lr"])
    assert row.hyperparameters["num_epochs"] == study.best_trial.params["epochs"]
    assert row.hyperparameters["batch_size"] == study.best_trial.params["batch-size"]
    assert row.status == "ready"
    assert Path(data["png"]).stat().st_size > 10_000
