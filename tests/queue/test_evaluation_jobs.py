"""Evaluation jobs share the training jobs' lifecycle: SIGTERM hands them back, a stop request ends them."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable

import pytest
import torch
from typer.testing import CliRunner

from drx.cli.main import app
from drx.evaluate.service import EvaluationRequest, list_evaluations
from drx.queue import lifecycle
from drx.queue.dispatch import run_job
from drx.queue.evaluate_job import enqueue_evaluation
from drx.registry import Checkpoint, session_scope
from drx.services.models import create_model, model_artifacts_dir
from drx.settings.hyperparameters import Hyperparameters
from drx.sim.env import DeepRacerEnv
from drx.sim.track import load_track
from drx.train.algorithms import build_algorithm
from drx.train.checkpoint import checkpoint_path, model_folder, save_checkpoint

DRX = [sys.executable, "-m", "drx.cli.main"]
LONG_RACE = EvaluationRequest(model="racer", laps=100, seed=1)  # minutes of driving: it never ends in a test


@pytest.fixture(autouse=True)
def _one_thread(monkeypatch: pytest.MonkeyPatch) -> None:
    """Job processes use one torch thread; 2 s leases, so heartbeats (and stop requests) come every 0.5 s."""
    monkeypatch.setenv("DRX_TORCH_THREADS", "1")
    monkeypatch.setenv("DRX_JOB_LEASE_SECONDS", "2")


def _racer() -> None:
    """Model ``racer`` (compact network, untrained weights) with a best checkpoint to race."""
    torch.set_num_threads(1)
    model = create_model("racer", network="compact")
    env = DeepRacerEnv(
        track=load_track(model.track_name), vehicle=model.vehicle(), mode="training", max_steps=50
    )
    hp = Hyperparameters.from_dict(model.hyperparameters, algorithm=model.algorithm)
    path = save_checkpoint(
        build_algorithm(env, model.vehicle().network, hp, seed=0),
        checkpoint_path(model_folder("racer"), "best"),
        {"iteration": 0},
    )
    with session_scope() as session:
        session.add(Checkpoint(model_id=model.id, iteration=0, path=str(path), is_best=True))


def _wait(predicate: Callable[[], bool], timeout: float, what: str) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return
        time.sleep(0.2)
    raise AssertionError(f"timed out waiting for {what}")


def _traces() -> list[str]:
    """The evaluation trace folders left in the model's folder."""
    return sorted(p.name for p in model_artifacts_dir("racer").glob("evaluation-*") if p.is_dir())


def test_a_stop_request_ends_a_running_evaluation_and_stores_nothing() -> None:
    _racer()
    job = enqueue_evaluation(LONG_RACE)
    assert (job.kind, job.max_attempts) == ("evaluate", 3)
    worker = lifecycle.new_worker_id()
    assert lifecycle.claim(job.id, worker)
    asked = threading.Timer(2.0, lambda: lifecycle.request_stop(job.id))  # mid-race, from "another shell"
    asked.start()
    started = time.monotonic()
    try:
        outcome = run_job(job.id, worker_id=worker)
    finally:
        asked.cancel()
    assert time.monotonic() - started < 30  # the race would run for minutes
    assert (outcome.status, outcome.stop_reason, outcome.evaluation_id) == ("stopped", "requested", None)
    row = lifecycle.get_job(job.id)
    assert (row.status, row.stop_reason, row.stop_requested) == ("stopped", "requested", True)
    assert [e["ended"] for e in row.attempt_log or []] == ["stopped"]
    assert list_evaluations() == [] and _traces() == []


def test_a_stale_stop_request_is_reset_when_the_evaluation_is_claimed_again() -> None:
    _racer()
    job = enqueue_evaluation(EvaluationRequest(model="racer", laps=1, max_resets=0, seed=1))
    first = lifecycle.new_worker_id() + "-first"
    assert lifecycle.claim(job.id, first) and lifecycle.request_stop(job.id) == "running"
    assert lifecycle.release(job.id, first, reason="its worker was shut down")  # before it saw the request
    assert lifecycle.get_job(job.id).status == "queued"
    outcome = run_job(job.id)  # claims it afresh: the old request does not stop the new attempt
    assert outcome.status == "succeeded" and outcome.evaluation_id is not None
    row = lifecycle.get_job(job.id)
    assert (row.status, row.stop_requested, row.attempts) == ("succeeded", False, 2)
    assert [e["ended"] for e in row.attempt_log or []] == ["requeued", "succeeded"]


def test_sigterm_hands_a_running_evaluation_back_to_the_queue() -> None:
    _racer()
    job = enqueue_evaluation(LONG_RACE)
    process = subprocess.Popen(
        [*DRX, "job", "run", str(job.id)],
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        env=dict(os.environ),
    )
    try:
        # A pose file of the race: the car drives (the SIGTERM handler is installed before the claim).
        _wait(lambda: any(model_artifacts_dir("racer").glob("live/*-evaluation.json")), 180, "the race")
        assert lifecycle.get_job(job.id).status == "running"
        process.send_signal(signal.SIGTERM)
        out, _ = process.communicate(timeout=60)
    finally:
        if process.poll() is None:
            process.kill()
    assert process.returncode == 0, out.decode()
    assert f"job {job.id} queued: worker shut down" in out.decode()
    row = lifecycle.get_job(job.id)
    assert (row.status, row.worker_id, row.attempts) == ("queued", None, 1)
    assert [(e["ended"], e["reason"]) for e in row.attempt_log or []] == [
        ("requeued", "its worker was shut down")
    ]
    assert list_evaluations() == [] and _traces() == []  # the interrupted race left nothing
    again = lifecycle.claim_next(lifecycle.new_worker_id())  # any worker takes it up again
    assert again is not None and (again.id, again.status, again.attempts) == (job.id, "running", 2)


def test_a_worker_sigterm_hands_its_running_evaluation_back_to_the_queue() -> None:
    _racer()
    job = enqueue_evaluation(LONG_RACE)
    worker = subprocess.Popen(
        [*DRX, "worker"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=dict(os.environ)
    )
    try:
        _wait(lambda: any(model_artifacts_dir("racer").glob("live/*-evaluation.json")), 180, "the race")
        worker.send_signal(signal.SIGTERM)  # the worker SIGTERMs its job process and waits for it
        out, _ = worker.communicate(timeout=90)
    finally:
        if worker.poll() is None:
            worker.kill()
    assert f"job {job.id} queued" in out.decode(), out.decode()
    row = lifecycle.get_job(job.id)
    assert (row.status, row.worker_id, row.attempts) == ("queued", None, 1)
    assert [(e["ended"], e["reason"]) for e in row.attempt_log or []] == [
        ("requeued", "its worker was shut down")
    ]
    assert list_evaluations() == [] and _traces() == []
    again = lifecycle.claim_next(lifecycle.new_worker_id())
    assert again is not None and (again.id, again.attempts) == (job.id, 2)


def test_drx_jobs_stop_says_a_running_evaluation_stores_nothing() -> None:
    _racer()
    job = enqueue_evaluation(EvaluationRequest(model="racer", laps=1, seed=1))
    assert lifecycle.claim(job.id, lifecycle.new_worker_id())
    result = CliRunner().invoke(app, ["jobs", "stop", str(job.id)])
    assert result.exit_code == 0, result.output
    assert f"Job {job.id} will stop at its next step, storing nothing." in result.output
    assert lifecycle.get_job(job.id).stop_requested
