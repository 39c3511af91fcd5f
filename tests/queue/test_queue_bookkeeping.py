"""Whatever ends an attempt leaves a reason in the job's attempt log and no rows past the last checkpoint."""

from __future__ import annotations

import json
import zipfile
from collections.abc import Callable

from sqlalchemy import select, update

from drx.queue import lifecycle
from drx.registry import Episode, Job, Model, session_scope
from drx.services.models import model_artifacts_dir

MakeModel = Callable[..., Model]


def _rows(model_id: int, iterations: range) -> None:
    with session_scope() as s:
        for it in iterations:
            for ep in range(5):
                s.add(
                    Episode(
                        model_id=model_id, iteration=it, episode=ep, phase="training", reward=1.0,
                        progress=5.0, steps=10, status="off_track", lap_time=None, start_fraction=0.0,
                    )
                )  # fmt: skip


def _checkpoint(name: str, iteration: int) -> None:
    folder = model_artifacts_dir(name)
    (folder / "model").mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(folder / "model" / "last.zip", "w") as zf:
        zf.writestr("drx.json", json.dumps({"iteration": iteration}))
    traces = folder / "training-simtrace"
    traces.mkdir(parents=True, exist_ok=True)
    for it in range(iteration + 2):
        (traces / f"{it}-iteration.csv").write_text("episode,steps\n")


def _iterations(model_id: int) -> list[int]:
    with session_scope() as s:
        return sorted(set(s.scalars(select(Episode.iteration).where(Episode.model_id == model_id))))


def test_the_last_attempt_keeps_only_checkpointed_rows_and_says_why(make_model: MakeModel) -> None:
    model = make_model()
    job = lifecycle.enqueue_training("m")
    assert lifecycle.claim(job.id, "host:1")
    _rows(model.id, range(2))
    _checkpoint("m", 0)
    assert lifecycle.release(job.id, "host:1", reason="its worker was shut down")  # attempt 1: requeued
    assert lifecycle.get_job(job.id).status == "queued"
    assert _iterations(model.id) == [0]  # removed with the requeue, in its transaction
    assert lifecycle.claim(job.id, "host:2")
    _rows(model.id, range(1, 2))
    with session_scope() as s:
        s.execute(update(Job).where(Job.id == job.id).values(attempts=Job.max_attempts))
    assert lifecycle.release(job.id, "host:2", reason="its worker went silent")  # the last attempt: failed
    done = lifecycle.get_job(job.id)
    assert done.status == "failed" and "its worker went silent" in (done.error or "")
    assert _iterations(model.id) == [0]
    traces = model_artifacts_dir("m") / "training-simtrace"
    assert sorted(p.name for p in traces.iterdir()) == ["0-iteration.csv"]  # no stray 1-iteration.csv
    log = done.attempt_log or []
    assert [(e["ended"], e["worker"], e["reason"]) for e in log] == [
        ("requeued", "host:1", "its worker was shut down"),
        ("failed", "host:2", "its worker went silent"),
    ]
    with session_scope() as s:
        assert s.scalar(select(Model.status).where(Model.id == model.id)) == "failed"


def test_finish_logs_the_attempt_and_truncates(make_model: MakeModel) -> None:
    model = make_model()
    job = lifecycle.enqueue_training("m")
    assert lifecycle.claim(job.id, "host:1")
    _rows(model.id, range(3))
    _checkpoint("m", 1)
    assert lifecycle.finish(job.id, "host:1", "failed", error="boom")
    assert _iterations(model.id) == [0, 1]
    assert [(e["ended"], e["reason"]) for e in lifecycle.get_job(job.id).attempt_log or []] == [
        ("failed", "boom")
    ]


def test_a_dead_local_holder_does_not_block_a_new_train(make_model: MakeModel) -> None:
    make_model()
    job = lifecycle.enqueue_training("m")
    dead = f"{lifecycle.socket.gethostname()}:999999999"
    assert lifecycle.claim(job.id, dead)
    again = lifecycle.enqueue_training("m")  # not refused: the holder is gone
    old = lifecycle.get_job(job.id)
    assert old.status == "failed" and "died" in (old.error or "") and again.status == "queued"
