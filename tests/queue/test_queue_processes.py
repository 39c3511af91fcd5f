"""Real processes: a worker killed with -9 mid-job, two workers sharing three jobs, the CLI end to end."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
import zipfile
from collections.abc import Callable
from pathlib import Path

import pytest
from sqlalchemy import func, select

from drx.queue import lifecycle
from drx.registry import Checkpoint, Episode, Model, session_scope
from drx.train.checkpoint import checkpoint_path, model_folder, read_meta

MakeModel = Callable[..., Model]
DRX = [sys.executable, "-m", "drx.cli.main"]


def _drx(*args: str, timeout: float = 240) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [*DRX, *args], capture_output=True, text=True, timeout=timeout, env=dict(os.environ)
    )


def _worker(*args: str) -> subprocess.Popen[bytes]:
    log = Path(os.environ["DRX_HOME"]) / f"worker-{time.monotonic_ns()}.log"
    log.parent.mkdir(parents=True, exist_ok=True)
    with log.open("wb") as out:
        return subprocess.Popen([*DRX, "worker", *args], stdout=out, stderr=subprocess.STDOUT)


def _wait(predicate: Callable[[], bool], timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return
        time.sleep(0.3)
    raise AssertionError(f"timed out waiting for {what}")


@pytest.fixture(autouse=True)
def _one_thread(monkeypatch: pytest.MonkeyPatch) -> None:
    """Job processes use one torch thread: robust on a busy test machine."""
    monkeypatch.setenv("DRX_TORCH_THREADS", "1")


@pytest.fixture
def short_lease(monkeypatch: pytest.MonkeyPatch) -> None:
    """Jobs enqueued in the test get a 2 s lease, so a dead worker's job is requeued quickly."""
    monkeypatch.setenv("DRX_JOB_LEASE_SECONDS", "2")


def test_kill_9_worker_then_resume_from_last_checkpoint(make_model: MakeModel, short_lease: None) -> None:
    model = make_model(max_episodes=15)
    job = lifecycle.enqueue_training("m", {"seed": 3, "eval_episodes": 1})
    first = _worker()

    def checkpoints() -> int:
        with session_scope() as s:
            return s.scalar(select(func.count(Checkpoint.id)).where(Checkpoint.model_id == model.id)) or 0

    try:
        _wait(lambda: checkpoints() >= 1, 240, "a checkpoint")
    finally:
        first.send_signal(signal.SIGKILL)
        first.wait(10)
    held_by = lifecycle.get_job(job.id).worker_id
    before = read_meta(checkpoint_path(model_folder("m"), "last"))["iteration"]
    assert lifecycle.get_job(job.id).status == "running" and before >= 0
    second = _worker("--exit-when-idle")
    try:
        second.wait(300)
    finally:
        if second.poll() is None:
            second.kill()
    done = lifecycle.get_job(job.id)
    assert done.status == "succeeded", done.error
    assert done.attempts == 2 and done.worker_id != held_by
    with session_scope() as s:
        rows = s.execute(
            select(Episode.iteration, Episode.episode).where(
                Episode.model_id == model.id, Episode.phase == "training"
            )
        ).all()
        iterations = s.scalars(select(Checkpoint.iteration).order_by(Checkpoint.iteration)).all()
    assert sorted(rows) == [(i, e) for i in range(3) for e in range(5)]  # none lost, none twice
    assert list(iterations) == list(range(3))
    folder = model_folder("m")
    assert read_meta(checkpoint_path(folder, "last"))["episodes"] == 15
    assert not [p for p in folder.rglob("*") if ".tmp" in p.name]
    for which in ("last", "best"):
        with zipfile.ZipFile(checkpoint_path(folder, which)) as zf:
            assert zf.testzip() is None


def test_two_workers_three_jobs(make_model: MakeModel) -> None:
    ids = []
    for name in ("a", "b", "c"):
        make_model(name, max_episodes=5)
        ids.append(lifecycle.enqueue_training(name, {"eval_episodes": 1}).id)
    workers = [_worker("--exit-when-idle"), _worker("--exit-when-idle")]
    for w in workers:
        w.wait(300)
    finished = [lifecycle.get_job(i) for i in ids]
    assert [j.status for j in finished] == ["succeeded"] * 3
    assert all(j.attempts == 1 for j in finished)  # claimed once each
    with session_scope() as s:
        assert s.scalar(select(func.count(Episode.id)).where(Episode.phase == "training")) == 15


def test_cli_train_detach_then_worker(make_model: MakeModel) -> None:
    from typer.testing import CliRunner

    from drx.cli.main import app

    def drx(*args: str) -> str:
        result = CliRunner().invoke(app, list(args))
        assert result.exit_code == 0, f"drx {' '.join(args)}: {result.output}"
        return result.stdout

    make_model(max_episodes=1000)
    assert "Queued job" in drx("train", "m", "--max-minutes", "1", "--max-episodes", "5", "--detach")
    job_id = lifecycle.list_jobs()[0][0].id
    worker = _drx("worker", "--exit-when-idle")
    assert worker.returncode == 0, worker.stderr
    shown = json.loads(drx("jobs", "show", str(job_id), "--json"))
    assert shown["status"] == "succeeded" and shown["stop_reason"] == "max_episodes"
    assert shown["options"]["stop"] == {"max_minutes": 1.0, "max_episodes": 5}
    assert "Reward per iteration" in drx("jobs", "logs", str(job_id))
    assert "succeeded" in drx("jobs", "list")
    log_file = Path(shown["log_path"])
    assert log_file.is_file() and "succeeded" in log_file.read_text()
