"""The trainer's run state read back from a checkpoint's metadata."""

from __future__ import annotations

from drx.train.run_state import RunState

META = {
    "iteration": 4, "steps": 900, "episodes": 60, "elapsed": 120.5, "sim_time": 60.0, "streak": 2,
    "job_steps": 300, "job_episodes": 20, "job_elapsed": 40.0, "run_key": "job-7", "eval_progress": 80.0,
}  # fmt: skip


def test_a_new_run_starts_at_zero() -> None:
    state = RunState()
    assert (state.iteration, state.steps, state.episodes, state.best) == (-1, 0, 0, None)


def test_the_same_job_continues_its_own_counters() -> None:
    state = RunState.resumed(META, {"iteration": 3}, same_job=True)
    assert (state.iteration, state.steps, state.episodes, state.elapsed, state.sim_time) == (
        4,
        900,
        60,
        120.5,
        60.0,
    )
    assert (state.job_steps, state.job_episodes, state.job_elapsed, state.streak) == (300, 20, 40.0, 2)
    assert state.best == {"iteration": 3}


def test_another_job_keeps_the_models_totals_and_starts_its_own() -> None:
    state = RunState.resumed(META, None, same_job=False)
    assert (state.iteration, state.steps, state.episodes) == (4, 900, 60)
    assert (state.job_steps, state.job_episodes, state.job_elapsed, state.streak, state.best) == (
        0,
        0,
        0.0,
        0,
        None,
    )
