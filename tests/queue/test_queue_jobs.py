"""The queue's state changes: atomic claims, heartbeats, expiry, stop, and a whole job in-process."""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Callable
from datetime import timedelta
from pathlib import Path

from sqlalchemy import func, select, update

from drx.queue import lifecycle
from drx.queue.dispatch import run_job
from drx.registry import Checkpoint, Episode, IterationMetric, Job, Model, session_scope, utcnow
from drx.train.checkpoint import checkpoint_path, model_folder, read_meta

MakeModel = Callable[..., Model]


def test_two_claims_one_winner(make_model: MakeModel) -> None:
    make_model()
    job = lifecycle.enqueue_training("m")
    wins: list[bool] = []
    barrier = threading.Barrier(4)

    def grab(i: int) -> None:
        barrier.wait()
        wins.append(lifecycle.claim(job.id, f"w{i}"))

    threads = [threading.Thread(target=grab, args=(i,)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert sorted(wins) == [False, False, False, True]
    assert lifecycle.get_job(job.id).attempts == 1
    assert lifecycle.claim_next("late") is None


def test_oldest_first_and_one_active_job_per_model(make_model: MakeModel) -> None:
    make_model("a")
    make_model("b")
    first = lifecycle.enqueue_training("a")
    second = lifecycle.enqueue_training("b")
    try:
        lifecycle.enqueue_training("a")
        raise AssertionError("a second job for the same model was accepted")
    except Exception as exc:  # DrxError
        assert "already has job" in str(exc)
    assert lifecycle.claim_next("w").id == first.id  # type: ignore[union-attr]
    assert lifecycle.claim_next("w").id == second.id  # type: ignore[union-attr]


def test_expired_lease_requeues_then_fails(make_model: MakeModel) -> None:
    make_model()
    job = lifecycle.enqueue_training("m")
    for attempt in range(1, 4):
        assert lifecycle.claim(job.id, "dead")
        assert lifecycle.heartbeat(job.id, "dead").held
        late = utcnow() + timedelta(seconds=job.lease_seconds + 1)
        assert lifecycle.requeue_expired(late) == [job.id]
        status = lifecycle.get_job(job.id).status
        assert status == ("queued" if attempt < 3 else "failed")
    assert "Gave up after 3 attempts" in (lifecycle.get_job(job.id).error or "")
    assert not lifecycle.heartbeat(job.id, "dead").held


def test_stop_cancels_a_queued_job(make_model: MakeModel) -> None:
    make_model()
    job = lifecycle.enqueue_training("m")
    assert lifecycle.request_stop(job.id) == "cancelled"
    assert lifecycle.claim_next("w") is None
    with session_scope() as s:
        assert s.scalar(select(Model.status).where(Model.name == "m")) == "draft"


def test_job_lifecycle_end_to_end(make_model: MakeModel) -> None:
    model = make_model(max_episodes=10)
    job = lifecycle.enqueue_training("m", {"seed": 1, "eval_episodes": 2})
    outcome = run_job(job.id)
    assert outcome.status == "succeeded" and outcome.stop_reason == "max_episodes"
    done = lifecycle.get_job(job.id)
    assert done.status == "succeeded" and done.stop_reason == "max_episodes" and done.finished_at is not None
    with session_scope() as s:
        train_rows = s.scalars(
            select(Episode).where(Episode.model_id == model.id, Episode.phase == "training")
        ).all()
        evals = s.scalar(select(func.count(Episode.id)).where(Episode.phase == "evaluation"))
        metrics = s.scalars(select(IterationMetric.iteration).order_by(IterationMetric.iteration)).all()
        health = s.scalars(select(IterationMetric.health)).all()
        cps = s.scalars(select(Checkpoint).order_by(Checkpoint.iteration)).all()
        status = s.scalar(select(Model.status).where(Model.id == model.id))
    assert sorted((r.iteration, r.episode) for r in train_rows) == [(i, e) for i in (0, 1) for e in range(5)]
    assert evals == 4 and list(metrics) == [0, 1] and [c.iteration for c in cps] == [0, 1]
    # each update's health figures are kept with the iteration (a discrete car: no spread, no bounds)
    expected = {"clip_fraction", "explained_variance", "return_scale", "epochs"}
    assert all(h and expected <= set(h) for h in health)
    assert sum(c.is_best for c in cps) == 1 and all(Path(c.path).is_file() for c in cps)
    assert status == "ready"
    assert read_meta(checkpoint_path(model_folder("m"), "last"))["episodes"] == 10


def test_stop_a_running_job_keeps_a_checkpoint(make_model: MakeModel) -> None:
    model = make_model(max_episodes=1000)
    job = lifecycle.enqueue_training("m", {"eval_episodes": 1})
    result: list = []
    thread = threading.Thread(target=lambda: result.append(run_job(job.id)))
    thread.start()
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        with session_scope() as s:
            if s.scalar(select(func.count(Episode.id)).where(Episode.model_id == model.id)):
                break
        time.sleep(0.2)
    assert lifecycle.request_stop(job.id) == "running"
    thread.join(180)
    assert result and result[0].status == "stopped"
    assert lifecycle.get_job(job.id).stop_reason == "requested"
    assert checkpoint_path(model_folder("m"), "last").is_file()


def test_raising_reward_fails_the_job(make_model: MakeModel, tmp_path: Path) -> None:
    reward = tmp_path / "flaky_reward.py"
    reward.write_text(
        "CALLS = [0]\n\n\ndef reward_function(params):\n    CALLS[0] += 1\n"
        "    if CALLS[0] > 300:\n        raise ValueError('boom')\n    return 1.0\n"
    )
    model = make_model(reward=reward, max_episodes=1000)
    job = lifecycle.enqueue_training("m", {"eval_episodes": 1})
    outcome = run_job(job.id)
    assert outcome.status == "failed"
    error = lifecycle.get_job(job.id).error or ""
    assert (
        "reward_function.py, line 7" in error and "boom" in error and "params:" in error and '"x":' in error
    )
    with session_scope() as s:
        assert s.scalar(select(Model.status).where(Model.id == model.id)) == "failed"
        last_cp = s.scalar(select(func.max(Checkpoint.iteration)))
        last_ep = s.scalar(select(func.max(Episode.iteration)))
    if last_cp is not None:  # rows never run past the last good checkpoint
        assert last_ep == last_cp
        assert read_meta(checkpoint_path(model_folder("m"), "last"))["iteration"] == last_cp


def test_lost_lease_is_not_finished_twice(make_model: MakeModel) -> None:
    make_model()
    job = lifecycle.enqueue_training("m")
    assert lifecycle.claim(job.id, "a")
    with session_scope() as s:
        s.execute(update(Job).where(Job.id == job.id).values(status="queued", worker_id=None))
    assert lifecycle.claim(job.id, "b")
    assert not lifecycle.finish(job.id, "a", "succeeded")
    assert lifecycle.finish(job.id, "b", "succeeded")


def test_clone_starts_from_the_parents_best(make_model: MakeModel) -> None:
    import numpy as np

    from drx.queue.train_job import build_spec
    from drx.services.models import clone_model
    from drx.train.evaluation import policy_outputs
    from drx.train.trainer import Trainer

    make_model("parent", max_episodes=5)
    assert run_job(lifecycle.enqueue_training("parent", {"eval_episodes": 1}).id).status == "succeeded"
    clone = clone_model("parent", "child")
    job = lifecycle.enqueue_training("child", {"seed": 7})
    spec = build_spec(lifecycle.get_job(job.id), clone)
    assert spec.init_checkpoint == checkpoint_path(model_folder("parent"), "best")
    child = Trainer(spec)
    parent_spec = build_spec(lifecycle.get_job(job.id), clone)
    parent_spec.init_checkpoint, parent_spec.seed = None, 1
    parent = Trainer(parent_spec)
    parent.model.set_parameters(str(checkpoint_path(model_folder("parent"), "best")))
    frames = np.random.default_rng(0).integers(0, 256, (3, 120, 160, 1), dtype=np.uint8)
    assert np.allclose(policy_outputs(child.model, frames), policy_outputs(parent.model, frames))


def test_reward_function_reads_the_racing_line(make_model: MakeModel, tmp_path: Path) -> None:
    reward = tmp_path / "racing_line_reward.py"
    reward.write_text(
        "import math\n\n\ndef reward_function(params):\n"
        "    x, y = params['racing_line'][params['closest_waypoints'][1]]\n"
        "    return 1.0 / (1.0 + math.hypot(params['x'] - x, params['y'] - y))\n"
    )
    make_model(reward=reward, max_episodes=5)
    job = lifecycle.enqueue_training("m", {"eval_episodes": 1})
    outcome = run_job(job.id)
    assert outcome.status == "succeeded", outcome.error


def test_jobs_logs_shows_the_models_episodes_per_iteration(make_model: MakeModel) -> None:
    """The dashboard of `drx jobs logs` reads the stored hyperparameters' own key (it read DeepRacer's
    `num_episodes_between_training`, absent from the registry, and always showed 0)."""
    from drx.cli.jobs import _dashboard_data

    make_model()
    job = lifecycle.enqueue_training("m")
    data, _ = _dashboard_data(job.id)
    assert data.episodes_per_iteration == 5


def test_jobs_show_says_when_training_has_collapsed(make_model: MakeModel) -> None:
    from typer.testing import CliRunner

    from drx.cli.main import app

    model = make_model()
    job = lifecycle.enqueue_training("m")

    def shown() -> dict:
        result = CliRunner().invoke(app, ["jobs", "show", str(job.id), "--json"])
        assert result.exit_code == 0, result.output
        return dict(json.loads(result.stdout))

    def add(iteration: int, progress: float) -> None:
        with session_scope() as s:
            row = IterationMetric(model_id=model.id, job_id=job.id, iteration=iteration)
            row.eval_mean_progress = progress
            s.add(row)

    for iteration, progress in enumerate([40.0, 100.0, 100.0]):
        add(iteration, progress)
    assert shown()["warning"] is None
    for iteration in range(3, 15):
        add(iteration, 6.0)
    assert "Training has collapsed" in shown()["warning"]
    text = CliRunner().invoke(app, ["jobs", "show", str(job.id)]).stdout
    assert "warning: Training has collapsed" in text and "drx model clone m m-2" in " ".join(text.split())


def test_jobs_show_and_logs_say_when_anneal_went_back_to_the_best(make_model: MakeModel) -> None:
    """The trainer's anneal figures reach the registry (with the health figures) through the
    job's sink; ``drx jobs show`` prints the rollback's sentence, ``drx jobs logs``'s dashboard too."""
    from typer.testing import CliRunner

    from drx.cli.jobs import _dashboard_data
    from drx.cli.main import app
    from drx.queue.registry_sink import RegistrySink
    from drx.train.records import IterationSummary

    model = make_model()
    job = lifecycle.enqueue_training("m")
    sink = RegistrySink(model.id, job.id)
    for iteration in range(5):
        summary = IterationSummary(
            iteration=iteration, steps=100 * iteration, episodes=5 * iteration, elapsed_seconds=10.0,
            steps_per_second=10.0, train_mean_reward=1.0, train_mean_progress=50.0, eval_mean_reward=1.0,
            eval_mean_progress=100.0, health={"clip_fraction": 0.1},
            extra={"lr_factor": 1.0, "collect_seconds": 2.0},
        )  # fmt: skip
        if iteration == 3:
            summary.extra.update(lr_factor=0.5, rollback_to=0.0, best_lap_time=8.1, next_learning_rate=1.5e-4)
        sink.on_iteration(summary, [])
    with session_scope() as s:
        rows = s.scalars(select(IterationMetric).order_by(IterationMetric.iteration)).all()
        assert rows[0].health == {"clip_fraction": 0.1, "lr_factor": 1.0}  # not the timings
        assert rows[3].health is not None and rows[3].health["rollback_to"] == 0.0
    sentence = (
        "iteration 3: 3 evaluations slower than 1.05x the best lap (8.10 s); back to the best "
        "checkpoint (iteration 0), learning rate 0.00015"
    )
    result = CliRunner().invoke(app, ["jobs", "show", str(job.id), "--json"])
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout)["rollback"] == sentence
    text = CliRunner().invoke(app, ["jobs", "show", str(job.id)]).stdout
    assert sentence in " ".join(text.split())
    data, _ = _dashboard_data(job.id)
    assert [s.extra.get("lr_factor") for s in data.iterations] == [1.0, 1.0, 1.0, 0.5, 1.0]
    assert "rollback_to" in data.iterations[3].extra
