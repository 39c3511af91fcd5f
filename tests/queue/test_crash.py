"""The queue's crash test: three workers, ``kill -9`` of workers and job processes at random moments.

Asserts, once every job has ended: each ended ``succeeded`` or ``failed`` with a reason;
the attempt log holds one ended attempt after the other (a job is claimed again only after
its holder's attempt ended); each model's training-episode rows are exactly its last checkpoint's episodes,
none twice; every checkpoint loads (weights only) into the car's network.

Runs on SQLite, or on PostgreSQL with ``DRX_TEST_DATABASE_URL`` (see tests/queue/conftest.py).
Prints its figures (kills, attempts, seconds). Slow (minutes): ``pytest -m slow tests/queue/test_crash.py``.
"""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest
from sqlalchemy import func, select

from drx.queue import lifecycle
from drx.registry import Episode, Model, session_scope
from drx.train.checkpoint import checkpoint_path, model_folder, read_meta
from drx.train.policy_weights import load_policy_weights

MakeModel = Callable[..., Model]
DRX = [sys.executable, "-m", "drx.cli.main"]
MODELS = ("c1", "c2", "c3", "c4")
KILLS = 6


def _worker(home: Path, n: int) -> subprocess.Popen[bytes]:
    log = home / f"crash-worker-{n}.log"
    log.parent.mkdir(parents=True, exist_ok=True)
    with log.open("ab") as out:
        return subprocess.Popen([*DRX, "worker", "--exit-when-idle"], stdout=out, stderr=subprocess.STDOUT)


def _children(pid: int) -> list[int]:
    proc = subprocess.run(["ps", "-o", "pid=", "--ppid", str(pid)], capture_output=True, text=True)
    return [int(p) for p in proc.stdout.split()]


def _all_done() -> bool:
    return all(
        j.status in ("succeeded", "failed", "stopped", "cancelled") for j, _ in lifecycle.list_jobs(limit=100)
    )


@pytest.mark.slow
def test_kill_9_workers_and_job_processes_at_random(
    make_model: MakeModel, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("DRX_TORCH_THREADS", "1")
    monkeypatch.setenv("DRX_JOB_LEASE_SECONDS", "3")
    home = Path(os.environ["DRX_HOME"])
    rng = random.Random(13)
    ids = []
    for name in MODELS:
        make_model(name, max_episodes=15)
        ids.append(lifecycle.enqueue_training(name, {"eval_episodes": 1, "seed": 1}).id)
    t0 = time.monotonic()
    workers = [_worker(home, n) for n in range(3)]
    kills: list[str] = []
    try:
        while len(kills) < KILLS and not _all_done() and time.monotonic() - t0 < 900:
            time.sleep(rng.uniform(3.0, 8.0))
            alive = [w for w in workers if w.poll() is None]
            children = [("job process", c) for w in alive for c in _children(w.pid)]
            # Alternate: job processes (mid-episode, mid-checkpoint...) and whole workers.
            targets = children if len(kills) % 2 == 0 and children else [("worker", w.pid) for w in alive]
            if not targets:
                break
            kind, pid = rng.choice(targets)
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                continue
            kills.append(kind)
            if kind == "worker":  # a new worker takes its place
                workers.append(_worker(home, len(workers)))
        deadline = time.monotonic() + 900
        while not _all_done() and time.monotonic() < deadline:
            if all(w.poll() is not None for w in workers):  # idle workers left before a lease ran out
                workers.append(_worker(home, len(workers)))
            time.sleep(1.0)
    finally:
        for w in workers:
            if w.poll() is None:
                w.send_signal(signal.SIGTERM)
                w.wait(60)
    seconds = time.monotonic() - t0
    ended = [lifecycle.get_job(i) for i in ids]
    print(
        f"\ncrash test on {os.environ.get('DRX_TEST_DATABASE_URL') and 'postgresql' or 'sqlite'}: "
        f"{len(kills)} kills ({kills.count('worker')} workers, {kills.count('job process')} job processes), "
        f"{len(workers)} workers started, attempts {[j.attempts for j in ended]}, "
        f"statuses {[j.status for j in ended]}, {seconds:.0f} s"
    )
    assert len(kills) >= 5
    for job, name in zip(ended, MODELS, strict=True):
        assert job.status in ("succeeded", "failed"), (job.id, job.status)
        if job.status == "failed":
            assert job.error
        log = job.attempt_log or []
        assert len(log) >= 1 and log[-1]["ended"] == job.status
        numbers = [e["attempt"] for e in log]  # one entry per attempt, one attempt after the other
        assert numbers == list(range(1, len(log) + 1)), log
        with session_scope() as s:
            model = s.scalar(select(Model).where(Model.name == name))
            assert model is not None
            rows = s.execute(
                select(Episode.iteration, Episode.episode).where(
                    Episode.model_id == model.id, Episode.phase == "training"
                )
            ).all()
            distinct = s.scalar(
                select(func.count()).select_from(
                    select(Episode.iteration, Episode.episode)
                    .where(Episode.model_id == model.id, Episode.phase == "training")
                    .distinct()
                    .subquery()
                )
            )
        last = checkpoint_path(model_folder(name), "last")
        checkpointed = read_meta(last)["episodes"] if last.is_file() else 0
        assert len(rows) == distinct == checkpointed, (name, len(rows), distinct, checkpointed)
        for which in ("last", "best"):
            path = checkpoint_path(model_folder(name), which)
            if path.is_file():
                load_policy_weights(path, model.vehicle(), model.algorithm)
