"""What the watch page shows besides pictures: the model to watch, the phase, the reward graph."""

from __future__ import annotations

import time

import pytest

from drx.errors import NotFoundError
from drx.queue import lifecycle
from drx.services.models import create_model
from drx.watch import state
from tests.watch.simulated import SimulatedJob


def test_no_model_yet_is_not_an_error() -> None:
    assert state.resolve_model(None) is None
    snap = state.snapshot(None)
    assert snap["model"] is None and snap["phase"] == state.NO_JOB and snap["graph"]["iteration"] == []


def test_an_unknown_model_names_the_known_ones() -> None:
    create_model("known", track="oval", network="compact")
    with pytest.raises(NotFoundError, match="No model named 'nosuch'; known models: known"):
        state.resolve_model("nosuch")


def test_without_a_name_the_newest_running_job_is_followed() -> None:
    create_model("a", track="oval", network="compact")
    create_model("b", track="oval", network="compact")
    assert state.resolve_model(None) == "b"  # no job: the newest model
    job = lifecycle.enqueue_training("a")
    assert state.resolve_model(None) == "a"  # the newest job
    lifecycle.claim(job.id, lifecycle.new_worker_id())
    lifecycle.enqueue_training("b")
    assert state.resolve_model(None) == "a"  # a running job comes before a queued one


def test_the_graph_gains_a_point_per_iteration(job: SimulatedJob) -> None:
    assert state.snapshot("wm")["graph"]["iteration"] == []
    job.end_iteration()
    job.end_iteration()
    snap = state.snapshot("wm")
    graph = snap["graph"]
    assert graph["iteration"] == [0, 1]
    assert graph["train_reward"] == [20.0, 27.0] and graph["train_progress"] == [10.0, 19.0]
    assert graph["eval_progress"] == [8.0, 19.0]
    assert snap["figures"]["iteration"] == 2 and snap["figures"]["steps"] == 200
    assert snap["job"]["status"] == "running" and snap["job"]["kind"] == "train"
    assert snap["figures"]["max_minutes"] == 5


def test_phases_follow_the_pose_files(job: SimulatedJob) -> None:
    assert state.snapshot("wm")["phase"] == state.STARTING  # running, no env has stepped yet
    job.drive("training")
    deadline = time.monotonic() + 20
    while state.snapshot("wm")["phase"] != state.SAMPLING and time.monotonic() < deadline:
        time.sleep(0.1)
    snap = state.snapshot("wm")
    assert snap["phase"] == state.SAMPLING and snap["pose"]["mode"] == "training"
    # The env stops stepping (the policy update): the same pose, seen later, is not live any more.
    pose = {"time": time.time(), "started": time.time(), "mode": "training"}
    job_d = snap["job"]
    assert state.phase_of(job_d, pose, time.time() + 3.0) == state.UPDATING
    assert state.phase_of(job_d, {**pose, "mode": "evaluation"}, time.time()) == state.EVALUATING
    old = {**pose, "started": time.time() - 3600}  # a pose from an earlier job's process
    assert state.phase_of(job_d, old, time.time()) == state.STARTING
    race = {**job_d, "kind": "evaluate"}
    assert state.phase_of(race, pose, time.time()) == state.RACING
    assert state.phase_of({**job_d, "status": "queued"}, None, time.time()) == state.QUEUED
    failed = {**job_d, "status": "failed", "error": "reward.py line 3: boom"}
    assert state.phase_of(failed, None, time.time()) == "failed: reward.py line 3: boom"
    # `drx evaluate` in the foreground has no job: a live evaluation pose is its race
    race_pose = {**pose, "mode": "evaluation"}
    assert state.phase_of(failed, race_pose, time.time()) == state.EVALUATING_HERE
    assert state.phase_of(None, race_pose, time.time()) == state.EVALUATING_HERE
    assert state.phase_of(None, race_pose, time.time() + 5) == state.NO_JOB
