"""The tables the trainer and the evaluator use: keys, cascades and timestamps."""

from __future__ import annotations

from datetime import UTC, datetime

import pytest
from sqlalchemy import func, select
from sqlalchemy.exc import IntegrityError

from drx.registry import (
    Checkpoint,
    Episode,
    Evaluation,
    EvaluationLap,
    IterationMetric,
    Job,
    Model,
    RewardSource,
    code_sha256,
    session_scope,
    utcnow,
)
from drx.vehicle import default_vehicle


def _model(session, name: str = "m") -> Model:
    code = "def reward_function(params):\n    return 1.0\n"
    if session.get(RewardSource, code_sha256(code)) is None:
        session.add(RewardSource(sha256=code_sha256(code), code=code, filename="r.py"))
    m = Model(
        name=name,
        vehicle_name="default",
        vehicle_spec=default_vehicle().to_dict(),
        track_name="oval",
        reward_sha256=code_sha256(code),
        reward_filename="r.py",
        algorithm="ppo",
        hyperparameters={},
        stop_conditions={},
    )
    session.add(m)
    session.flush()
    return m


def test_a_training_run_is_recorded_and_removed_with_its_model() -> None:
    with session_scope() as s:
        m = _model(s)
        job = Job(model_id=m.id, kind="train", options={"seed": 1})
        s.add(job)
        s.flush()
        assert (job.status, job.attempts, job.max_attempts, job.stop_requested) == ("queued", 0, 3, False)
        s.add(Checkpoint(model_id=m.id, job_id=job.id, iteration=1, path="a.zip", is_best=True))
        s.add(Episode(model_id=m.id, job_id=job.id, iteration=1, episode=0, phase="training",
                      reward=3.0, progress=12.5, steps=40, status="off_track"))  # fmt: skip
        s.add(IterationMetric(model_id=m.id, job_id=job.id, iteration=1, policy_loss=0.1, steps=40))
        ev = Evaluation(model_id=m.id, track_name="oval", rules={"laps": 3})
        ev.laps.append(EvaluationLap(lap=1, time=12.3, progress=100.0, status="lap_complete"))
        s.add(ev)
    with session_scope() as s:
        assert s.scalar(select(func.count(EvaluationLap.id))) == 1
        s.delete(s.scalar(select(Model)))
    with session_scope() as s:
        for table in (Job, Checkpoint, Episode, IterationMetric, Evaluation, EvaluationLap):
            assert s.scalar(select(func.count()).select_from(table)) == 0, table.__tablename__


def test_an_episode_is_never_counted_twice() -> None:
    with session_scope() as s:
        m = _model(s)
        row = {"model_id": m.id, "iteration": 1, "episode": 0, "reward": 1.0, "progress": 5.0, "steps": 3,
               "status": "off_track"}  # fmt: skip
        s.add(Episode(phase="training", **row))
        s.add(Episode(phase="evaluation", **row))  # another phase is another episode
    with pytest.raises(IntegrityError), session_scope() as s:
        s.add(Episode(phase="training", **row))


def test_foreign_keys_are_enforced() -> None:
    with pytest.raises(IntegrityError), session_scope() as s:
        s.add(Job(model_id=999, kind="train"))


def test_timestamps_are_utc_aware() -> None:
    with session_scope() as s:
        m = _model(s)
        job = Job(model_id=m.id, kind="train", heartbeat_at=datetime(2026, 1, 2, 3, 4, 5, tzinfo=UTC))
        s.add(job)
    with session_scope() as s:
        job = s.scalar(select(Job))
        assert job.heartbeat_at == datetime(2026, 1, 2, 3, 4, 5, tzinfo=UTC)
        assert job.created_at.tzinfo is not None
        assert abs((utcnow() - job.created_at).total_seconds()) < 60


def test_clone_parent_link() -> None:
    with session_scope() as s:
        parent = _model(s, "parent")
        child = _model(s, "child")
        child.parent_id, child.parent_name = parent.id, parent.name
    with session_scope() as s:
        parent = s.scalar(select(Model).where(Model.name == "parent"))
        assert [c.name for c in parent.children] == ["child"]
