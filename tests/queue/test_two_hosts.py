"""Two hosts, simulated here: two ``drx worker`` processes with their own data homes and caches,
sharing only the PostgreSQL registry and the S3 bucket (both started by the tests on 127.0.0.1).

Host A trains until two checkpoints are stored, then it is killed with SIGKILL (worker and job
process together, as when a machine dies). Host B's worker notices the silent lease, takes the
job and resumes from the checkpoint host A stored. The job ends once; every training episode
has exactly one row; the model evaluates from either host.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import psutil
import pytest
from _servers import Postgres, S3Server
from sqlalchemy import func, select

from drx.queue import lifecycle
from drx.registry import Checkpoint, Episode, Job, Model, session_scope
from drx.registry.engine import dispose_engines
from drx.registry.testing import empty_database
from drx.services.models import create_model
from drx.storage import get_store, reset_stores

ROOT = Path(__file__).resolve().parents[2]
DRX = [sys.executable, "-m", "drx.cli.main"]
EPISODES_PER_ITERATION = 5
MAX_EPISODES = 20  # four iterations: two on host A, two on host B
BUCKET = "drx-two-hosts"


def _host_env(home: Path, shared: dict[str, str]) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("DRX_", "AWS_"))}
    return {**env, **shared, "DRX_HOME": str(home), "PYTHONPATH": str(ROOT), "DRX_EVALUATION_SEED": "0"}


def _worker(home: Path, shared: dict[str, str]) -> subprocess.Popen[bytes]:
    home.mkdir(parents=True, exist_ok=True)
    with (home / "worker.log").open("ab") as log:
        return subprocess.Popen(
            [*DRX, "worker", "--exit-when-idle"],
            stdout=log,
            stderr=subprocess.STDOUT,
            env=_host_env(home, shared),
            start_new_session=True,
        )


def _kill_host(worker: subprocess.Popen[bytes]) -> int:
    """SIGKILL the worker and its job process at once; how many processes died."""
    procs = [psutil.Process(worker.pid), *psutil.Process(worker.pid).children(recursive=True)]
    for p in procs:
        p.send_signal(signal.SIGKILL)
    worker.wait(30)
    psutil.wait_procs(procs, timeout=30)
    return len(procs)


def _stored_checkpoints(model_id: int) -> int:
    with session_scope() as s:
        return int(s.scalar(select(func.count(Checkpoint.id)).where(Checkpoint.model_id == model_id)) or 0)


def test_a_host_killed_mid_training_is_resumed_by_another(
    postgres_server: Postgres, s3_server: S3Server, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    s3_server.make_bucket(BUCKET)
    shared = {
        "DRX_DATABASE_URL": postgres_server.url,
        "DRX_ARTIFACTS_URL": f"s3://{BUCKET}/fleet",
        "DRX_JOB_LEASE_SECONDS": "3",
        "DRX_TORCH_THREADS": "1",
        **s3_server.env(),
    }
    empty_database(postgres_server.url)
    home_a, home_b = tmp_path / "host-a", tmp_path / "host-b"
    for key, value in _host_env(home_a, shared).items():  # this test process is host A's shell
        monkeypatch.setenv(key, value)
    dispose_engines()
    reset_stores()
    model = create_model(
        "m",
        track="oval",
        reward="follow_center_line",
        network="compact",
        hyperparameters={"episodes_per_iteration": EPISODES_PER_ITERATION},
        stop_conditions={"max_episodes": MAX_EPISODES},
    )
    job_id = lifecycle.enqueue_training("m", {"eval_episodes": 1, "seed": 1}).id
    t0 = time.monotonic()

    worker_a = _worker(home_a, shared)
    worker_b = None
    try:
        while _stored_checkpoints(model.id) < 2:
            assert worker_a.poll() is None, (home_a / "worker.log").read_text()[-3000:]
            assert time.monotonic() - t0 < 300, "host A stored no two checkpoints in 300 s"
            time.sleep(0.2)
        killed = _kill_host(worker_a)
        with session_scope() as s:
            durable = int(
                s.scalar(select(func.max(Checkpoint.iteration)).where(Checkpoint.model_id == model.id))
            )
            before = {
                (r.phase, r.iteration, r.episode): r.id
                for r in s.scalars(select(Episode).where(Episode.model_id == model.id))
                if r.iteration <= durable
            }
            held_by_a = s.get_one(Job, job_id).worker_id
        t_kill = time.monotonic() - t0

        worker_b = _worker(home_b, shared)
        worker_b.wait(600)
    finally:
        for w in (worker_a, worker_b):
            if w is not None and w.poll() is None:
                _kill_host(w)
    seconds = time.monotonic() - t0
    log_b = (home_b / "worker.log").read_text()
    assert worker_b.returncode == 0, log_b[-3000:]

    # The job finished exactly once, on host B, after host A's attempt was handed back.
    job = lifecycle.get_job(job_id)
    assert job.status == "succeeded", (job.status, job.error, log_b[-2000:])
    log = job.attempt_log or []
    assert [e["ended"] for e in log] == ["requeued", "succeeded"], log
    assert log[0]["worker"] == held_by_a != log[1]["worker"] == job.worker_id
    with session_scope() as s:
        assert s.scalar(select(func.count(Job.id)).where(Job.model_id == model.id)) == 1
        rows = list(s.scalars(select(Episode).where(Episode.model_id == model.id)))
        paths = list(s.scalars(select(Checkpoint.path).where(Checkpoint.model_id == model.id)))
        assert s.scalar(select(Model.status).where(Model.id == model.id)) == "ready"

    # No episode row lost or duplicated: one row per training episode of every iteration.
    training = sorted((r.iteration, r.episode) for r in rows if r.phase == "training")
    iterations = MAX_EPISODES // EPISODES_PER_ITERATION
    assert training == [(i, e) for i in range(iterations) for e in range(EPISODES_PER_ITERATION)]
    # Host B resumed from host A's stored checkpoint: A's durable rows are the very same rows.
    after = {(r.phase, r.iteration, r.episode): r.id for r in rows if r.iteration <= durable}
    assert after == before and len(before) >= 2 * EPISODES_PER_ITERATION

    # Every file is in the bucket; host B fetched host A's checkpoint into its own cache.
    store = get_store()
    assert all(p.startswith(f"s3://{BUCKET}/fleet/models/m/") for p in paths), paths
    stored = store.listing("m", "")
    assert {"model/last.zip", "model/best.zip", "model/model_metadata.json"} <= set(stored)
    assert [s for s in stored if s.startswith("training-simtrace/")] == sorted(
        f"training-simtrace/{i}-iteration.csv" for i in range(iterations)
    )
    assert f"logs/job-{job_id}.log" in stored  # host B's log of the job, readable from host A
    cache_b = home_b / "cache" / "s3" / BUCKET / "fleet" / "models" / "m"
    assert (cache_b / ".drx-store" / "model" / "last.zip.json").is_file()

    # The model evaluates from either host (host A's stale cached checkpoint is refreshed first).
    results = {}
    for host, home in (("a", home_a), ("b", home_b)):
        video = ["--video", str(tmp_path / "lap.mp4")] if host == "b" else []
        proc = subprocess.run(
            [*DRX, "evaluate", "m", "--laps", "1", "--time-cap-minutes", "0.2", *video, "--json"],
            capture_output=True,
            text=True,
            env=_host_env(home, shared),
            timeout=300,
        )
        assert proc.returncode == 0, proc.stderr[-2000:]
        results[host] = json.loads(proc.stdout)
    assert results["a"]["checkpoint_iteration"] == results["b"]["checkpoint_iteration"] is not None
    stored = store.listing("m", "")
    assert len([s for s in stored if s.startswith("evaluation-") and s.endswith("0-iteration.csv")]) == 2
    assert len([s for s in stored if s.startswith("videos/evaluation-") and s.endswith(".mp4")]) == 1
    cache_a = home_a / "cache" / "s3" / BUCKET / "fleet" / "models" / "m"
    assert (cache_a / "model" / "best.zip").read_bytes() == (cache_b / "model" / "best.zip").read_bytes()
    print(
        f"\ntwo hosts on PostgreSQL + S3: host A killed ({killed} processes) at {t_kill:.0f} s after "
        f"iteration {durable}; host B finished {iterations} iterations; {seconds:.0f} s in all"
    )
