"""The runner's sweep hook, in-process with real training: report, prune, complete, resume, reconcile.

The task built to prune: the sweep already holds a finished trial whose evaluation earned more reward
in every iteration than any evaluation can, so a trial trained from scratch for a few episodes is
stopped by the median pruner once its warm-up iteration is over.
"""

from __future__ import annotations

from pathlib import Path

import optuna
import pytest
from optuna.distributions import FloatDistribution
from optuna.trial import TrialState, create_trial
from sqlalchemy import func, select

from drx.queue import lifecycle
from drx.queue.dispatch import run_job
from drx.registry import IterationMetric, session_scope
from drx.services.models import get_model
from drx.sweep.service import create_sweep, extend_sweep, load_sweep, trial_rows
from drx.sweep.trial import PRUNED, SweepTrial
from tests.cli.helpers import ok

from .conftest import MakeModel


@pytest.fixture(autouse=True)
def _one_thread(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("DRX_TORCH_THREADS", "1")


def _iterations(model: str) -> int:
    with session_scope() as s:
        model_id = get_model(model).id
        return (
            s.scalar(select(func.count(IterationMetric.id)).where(IterationMetric.model_id == model_id)) or 0
        )


REFERENCE_REWARD = 1e9  # a finished trial's reward in every iteration: more than any evaluation earns


def _add_reference(study: optuna.Study, value: float, iterations: int) -> None:
    """A finished trial that reached ``value`` in every iteration (what the pruner compares with)."""
    study.add_trial(
        create_trial(
            params={"lr": 3e-4},
            distributions={"lr": FloatDistribution(1e-5, 1e-3, log=True)},
            value=value,
            intermediate_values=dict.fromkeys(range(iterations), value),
            user_attrs={"model": None},
        )
    )


def test_a_trial_behind_the_median_is_pruned_early(make_source: MakeModel) -> None:
    make_source(max_episodes=25)  # up to 5 iterations of 5 episodes
    # Reward, not progress: an untrained model sometimes laps the oval in its first evaluation (100%
    # progress ties the reference, and the median pruner judges a trial by its best figure so far).
    create_sweep("s", "base", 1, ["lr=1e-5:1e-3:log"], metric="reward", startup_trials=1, warmup_iterations=1)
    _, study = load_sweep("s")
    _add_reference(study, REFERENCE_REWARD, iterations=5)
    job = lifecycle.get_job(study.trials[0].user_attrs["job"])

    outcome = run_job(job.id, trial_for=SweepTrial.of)

    trial = optuna.load_study(study_name="s", storage=study._storage).trials[0]
    assert outcome.status == "succeeded" and outcome.stop_reason == PRUNED, trial.intermediate_values
    assert lifecycle.get_job(job.id).stop_reason == PRUNED
    assert trial.state == TrialState.PRUNED
    assert sorted(trial.intermediate_values) == [0, 1]  # iteration 0 is warm-up; pruned after 1
    assert all(v < REFERENCE_REWARD for v in trial.intermediate_values.values())
    assert _iterations("s-0") == 2 < 5  # stopped early: its stop condition allowed 5
    assert get_model("s-0").status == "ready"  # an ordinary model with its checkpoints
    rows = trial_rows(*load_sweep("s"))
    assert [r.state for r in rows] == ["complete", "pruned"]


def test_a_trial_completes_with_its_best_iteration_and_keeps_its_params(
    make_source: MakeModel, tmp_path: Path
) -> None:
    make_source(max_episodes=10)
    create_sweep("s", "base", 1, ["lr=1e-5:1e-3:log", "batch-size=32,64"], metric="reward")
    _, study = load_sweep("s")
    job_id = study.trials[0].user_attrs["job"]

    outcome = run_job(job_id, trial_for=SweepTrial.of)

    assert outcome.status == "succeeded" and outcome.stop_reason == "max_episodes"
    trial = optuna.load_study(study_name="s", storage=study._storage).trials[0]
    assert trial.state == TrialState.COMPLETE and len(trial.intermediate_values) == 2
    assert trial.value == max(trial.intermediate_values.values())
    with session_scope() as s:
        rewards = s.scalars(
            select(IterationMetric.eval_mean_reward).where(IterationMetric.model_id == get_model("s-0").id)
        ).all()
    assert sorted(trial.intermediate_values.values()) == pytest.approx(sorted(rewards))
    hp = get_model("s-0").hyperparameters
    assert (
        hp["learning_rate"] == pytest.approx(trial.params["lr"])
        and hp["batch_size"] == trial.params["batch-size"]
    )

    # the trial is an ordinary model: it evaluates, clones and exports
    ok("evaluate", "s-0", "--laps", "1", "--max-resets", "2")
    ok("model", "clone", "s-0", "s0-next")
    ok("model", "export", "s-0", "--out", tmp_path / "s-0.tar.gz")
    assert get_model("s0-next").hyperparameters["learning_rate"] == pytest.approx(trial.params["lr"])

    # told, then the worker died before ending the job: the requeued job does not train again
    with session_scope() as s:
        from drx.registry import Job

        s.get_one(Job, job_id).status = "queued"
    again = run_job(job_id, trial_for=SweepTrial.of)
    assert again.result is not None and again.result.iterations == 0 and _iterations("s-0") == 2

    # the finished sweep takes more trials, queued like the first
    assert extend_sweep("s", 2) == [1, 2]
    rows = trial_rows(*load_sweep("s"))
    assert [(r.number, r.state) for r in rows] == [(0, "complete"), (1, "queued"), (2, "queued")]
    assert {get_model(f"s-{n}").status for n in (1, 2)} == {"queued"}


def test_a_trial_stopped_by_hand_counts_as_pruned_and_a_failed_one_fails(make_source: MakeModel) -> None:
    make_source(max_episodes=10)
    create_sweep("s", "base", 2, ["lr=1e-5:1e-3:log"])
    spec, study = load_sweep("s")
    first, second = (t.user_attrs["job"] for t in study.trials)
    storage = study._storage
    trial_id = storage.get_trial_id_from_study_id_trial_number(storage.get_study_id_from_name("s"), 0)
    storage.set_trial_intermediate_value(trial_id, 0, 12.5)  # one iteration reported, then stopped
    worker = lifecycle.new_worker_id()
    assert lifecycle.claim(first, worker) and lifecycle.finish(
        first, worker, "stopped", stop_reason="requested"
    )
    assert lifecycle.request_stop(second) == "cancelled"  # never started: no iteration
    states = {r.number: (r.state, r.value) for r in trial_rows(spec, study)}
    assert states == {0: ("pruned", 12.5), 1: ("fail", None)}


def test_a_trial_run_without_its_sweep_fails_rather_than_train_unreported(make_source: MakeModel) -> None:
    """The queue does not import the sweep: whoever runs a trial's job passes the sweep's trial finder."""
    make_source(max_episodes=5)
    create_sweep("s", "base", 1, ["lr=1e-5:1e-3:log"], metric="reward")
    _, study = load_sweep("s")
    job_id = study.trials[0].user_attrs["job"]

    outcome = run_job(job_id)

    assert outcome.status == "failed" and "sweep trial" in (outcome.error or "")
    assert _iterations("s-0") == 0
