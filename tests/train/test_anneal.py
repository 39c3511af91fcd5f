"""The ``anneal`` schedule: back to the best checkpoint at half the rate when the laps stop keeping
its pace (drx/train/anneal.py's rules, and the trainer applying them to PPO and SAC)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
import torch as th
from stable_baselines3.common.save_util import load_from_zip_file

import drx.train.trainer as trainer_module
from drx.settings.hyperparameters import HELP
from drx.settings.stop import StopConditions
from drx.train.anneal import (
    FLOOR,
    STRIKES,
    TOLERANCE,
    AnnealState,
    best_lap_time,
    judge,
    latest_rollback,
    rollback_message,
    summary_rollback,
    wrap,
)
from drx.train.checkpoint import checkpoint_path, read_meta
from drx.train.records import EpisodeRecord
from drx.train.trainer import Trainer, TrainingSpec

from .conftest import SpecFactory, compact_car

BEST = {"iteration": 7, "eval_progress": 100.0, "eval_lap_time": 8.0}
SLOW = 8.0 * TOLERANCE + 0.01  # [s] just past the tolerance


def _slow(state: AnnealState, times: int, best: dict[str, Any] | None = BEST) -> list[Any]:
    verdicts = []
    for _ in range(times):
        verdict = judge(state, best, evaluated=True, lap_time=SLOW)
        verdicts.append(verdict)
        state = verdict.state
    return verdicts


# ----- the rules ---------------------------------------------------------------------------
def test_within_the_tolerance_holds_and_clears_the_strikes() -> None:
    verdict = judge(AnnealState(strikes=2), BEST, evaluated=True, lap_time=8.0 * TOLERANCE)
    assert verdict.held is True and not verdict.rollback and verdict.state == AnnealState()


def test_three_slow_evaluations_in_a_row_roll_back_at_half_the_rate() -> None:
    verdicts = _slow(AnnealState(), STRIKES)
    assert [v.held for v in verdicts] == [False] * STRIKES
    assert [v.rollback for v in verdicts] == [False] * (STRIKES - 1) + [True]
    assert [v.state.strikes for v in verdicts] == [*range(1, STRIKES), 0]  # reset by the rollback
    assert verdicts[-1].state == AnnealState(factor=0.5, strikes=0, rollbacks=1)
    after = _slow(verdicts[-1].state, STRIKES)[-1]  # three more: a second rollback, a quarter
    assert after.rollback and after.state == AnnealState(factor=0.25, strikes=0, rollbacks=2)


def test_a_missed_lap_is_a_strike() -> None:
    """An evaluation with an episode off the track has no mean lap time (None): it does not hold."""
    verdict = judge(AnnealState(), BEST, evaluated=True, lap_time=None)
    assert verdict.held is False and verdict.state.strikes == 1


def test_a_hold_between_slow_evaluations_starts_the_count_again() -> None:
    state = _slow(AnnealState(), STRIKES - 1)[-1].state
    state = judge(state, BEST, evaluated=True, lap_time=8.1).state
    assert state.strikes == 0
    assert not any(v.rollback for v in _slow(state, STRIKES - 1))


def test_a_new_best_holds_and_resets_the_strikes() -> None:
    state = AnnealState(factor=0.5, strikes=STRIKES - 1, rollbacks=1)
    verdict = judge(state, BEST, evaluated=True, lap_time=7.5, new_best=True)
    assert verdict.held is True and not verdict.rollback
    assert verdict.state == AnnealState(factor=0.5, strikes=0, rollbacks=1)  # the rate stays annealed


def test_unevaluated_iterations_count_neither_way() -> None:
    state = AnnealState(strikes=STRIKES - 1)
    for lap_time in (None, SLOW, 8.0):
        verdict = judge(state, BEST, evaluated=False, lap_time=lap_time)
        assert verdict.held is None and not verdict.rollback and verdict.state == state


def test_nothing_happens_before_the_best_laps() -> None:
    """No best, or a best whose evaluation missed a lap (no lap time, or progress short of 100%)."""
    unlapped = [None, {"iteration": 3, "eval_progress": 80.0, "eval_lap_time": None},
                {"iteration": 3, "eval_progress": 99.0, "eval_lap_time": 8.0}]  # fmt: skip
    for best in unlapped:
        assert best_lap_time(best) is None
        verdicts = _slow(AnnealState(), 2 * STRIKES, best)
        assert all(v.held is None and not v.rollback for v in verdicts)
        assert verdicts[-1].state == AnnealState()
    assert best_lap_time(BEST) == 8.0


def test_the_rate_stops_falling_at_its_floor_but_still_rolls_back() -> None:
    state = AnnealState()
    factors = []
    for _ in range(8):
        verdict = _slow(state, STRIKES)[-1]
        assert verdict.rollback
        state = verdict.state
        factors.append(state.factor)
    assert factors == [0.5, 0.25, 0.125, 0.0625, FLOOR, FLOOR, FLOOR, FLOOR]
    assert FLOOR == 1 / 32 and state.rollbacks == 8


def test_the_state_travels_in_a_checkpoints_metadata() -> None:
    state = AnnealState(factor=0.25, strikes=1, rollbacks=2)
    assert AnnealState.from_meta(state.to_meta()) == state
    assert AnnealState.from_meta({"iteration": 3}) == AnnealState()  # a checkpoint from before anneal


def test_the_rollback_sentence_fits_two_log_lines() -> None:
    text = rollback_message(40, 28, 8.1, 1.5e-4)
    assert text == (
        "iteration 40: 3 evaluations slower than 1.05x the best lap (8.10 s); back to the best "
        "checkpoint (iteration 28), learning rate 0.00015"
    )
    extra = {"rollback_to": 28.0, "best_lap_time": 8.1, "next_learning_rate": 1.5e-4, "lr_factor": 0.5}
    assert summary_rollback(40, extra) == text
    assert summary_rollback(40, {"lr_factor": 0.5}) is None


def test_the_help_says_the_rule() -> None:
    assert f"{STRIKES} evaluations" in HELP["lr_schedule"] and f"{TOLERANCE:g}x" in HELP["lr_schedule"]
    assert "[default: anneal]" in HELP["lr_schedule"]


# ----- the trainer -------------------------------------------------------------------------
LAPS = {0: 8.0, 1: SLOW, 2: SLOW, 3: SLOW, 4: 8.2, 5: 8.2}  # [s] each iteration's scripted evaluation laps


@pytest.fixture
def scripted_laps(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every evaluation episode completes the lap in ``LAPS[iteration]`` seconds."""

    def evaluate(_m: Any, _e: Any, _c: Any, iteration: int, episodes: int, **_: Any) -> list[EpisodeRecord]:
        lap = LAPS[iteration]
        return [EpisodeRecord(iteration=iteration, episode=i, global_episode=i, phase="evaluation",
                              reward=10.0, progress=100.0, steps=int(lap * 15), status="lap_complete",
                              lap_time=lap) for i in range(episodes)]  # fmt: skip

    monkeypatch.setattr(trainer_module, "evaluate", evaluate)


def _spec(corridor_spec: SpecFactory, algorithm: str, iterations: int, **hp: Any) -> TrainingSpec:
    per_iteration = 5 if algorithm == "ppo" else 1
    spec = corridor_spec(
        stop=StopConditions(max_minutes=None, max_episodes=iterations * per_iteration),
        car=compact_car(continuous=algorithm == "sac"), algorithm=algorithm, learning_rate=1e-3,
        episodes_per_iteration=per_iteration, **hp,
    )  # fmt: skip
    spec.run_key = "job-1"  # the same job throughout: a resumed trainer is its next attempt
    return spec


def _checkpoint(path: Path) -> tuple[dict[str, th.Tensor], list[float]]:
    """A checkpoint's policy weights and its optimizers' rates."""
    _, params, _ = load_from_zip_file(path)
    assert params is not None
    rates = [g["lr"] for name, state in params.items() if name.endswith("optimizer")
             for g in state["param_groups"]]  # fmt: skip
    return params["policy"], rates


def _rates(trainer: Trainer) -> list[float]:
    return [g["lr"] for opt in trainer.model.rate_optimizers() for g in opt.param_groups]


@pytest.mark.usefixtures("scripted_laps")
@pytest.mark.parametrize("algorithm", ["ppo", "sac"])
def test_a_rollback_restores_the_best_and_halves_the_optimizers_rate(
    corridor_spec: SpecFactory, algorithm: str
) -> None:
    spec = _spec(corridor_spec, algorithm, iterations=5)  # the default schedule: anneal
    assert spec.hyperparameters.lr_schedule == "anneal"
    lasts: dict[int, dict[str, th.Tensor]] = {}

    class Keep(trainer_module.NullSink):
        def on_checkpoint(self, record: Any) -> None:
            lasts[record.iteration] = _checkpoint(Path(record.path))[0]

    result = Trainer(spec, Keep()).run()
    summaries = {s.iteration: s for s in result.summaries}
    assert sorted(summaries) == [0, 1, 2, 3, 4]
    assert [summaries[i].extra["lr_factor"] for i in range(5)] == [1.0, 1.0, 1.0, 0.5, 0.5]
    assert [("rollback_to" in summaries[i].extra) for i in range(5)] == [False, False, False, True, False]
    assert summaries[3].extra["rollback_to"] == 0 and summaries[3].extra["best_lap_time"] == 8.0
    assert summaries[3].extra["next_learning_rate"] == pytest.approx(5e-4)
    # the update of iteration 3 ran at the full rate, the next at half
    assert [summaries[i].learning_rate for i in range(5)] == pytest.approx([1e-3] * 4 + [5e-4])

    best_weights, _ = _checkpoint(checkpoint_path(spec.folder, "best"))
    assert any(not th.equal(best_weights[k], lasts[2][k]) for k in best_weights)  # it had drifted
    assert all(th.equal(best_weights[k], lasts[3][k]) for k in best_weights)  # `last` went back
    _, rates = _checkpoint(checkpoint_path(spec.folder, "last"))
    assert rates and rates == pytest.approx([5e-4] * len(rates))
    meta = read_meta(checkpoint_path(spec.folder, "last"))
    assert (meta["lr_factor"], meta["anneal_strikes"], meta["rollbacks"]) == (0.5, 0, 1)
    assert read_meta(checkpoint_path(spec.folder, "best"))["iteration"] == 0

    # a resumed run (a killed job's next attempt) goes on at the annealed rate ...
    resumed = Trainer(_spec(corridor_spec, algorithm, iterations=6))
    assert resumed.model.lr_factor == 0.5 and _rates(resumed) == pytest.approx([5e-4] * len(_rates(resumed)))
    again = resumed.run().summaries
    assert [s.iteration for s in again] == [5] and again[0].learning_rate == pytest.approx(5e-4)
    assert _rates(resumed) == pytest.approx([5e-4] * len(_rates(resumed)))
    # ... and a clone starts at the full rate
    clone_spec = _spec(corridor_spec, algorithm, iterations=1)
    clone_spec.folder = spec.folder.with_name("clone")
    clone_spec.init_checkpoint = checkpoint_path(spec.folder, "last")
    clone = Trainer(clone_spec)
    assert clone.model.lr_factor == 1.0 and clone.state.lr_factor == 1.0
    assert _rates(clone) == pytest.approx([1e-3] * len(_rates(clone)))
    clone.close()


@pytest.mark.usefixtures("scripted_laps")
def test_other_schedules_never_roll_back(corridor_spec: SpecFactory) -> None:
    spec = _spec(corridor_spec, "ppo", iterations=5, lr_schedule="constant")
    summaries = Trainer(spec).run().summaries
    assert all("lr_factor" not in s.extra and "rollback_to" not in s.extra for s in summaries)
    assert [s.learning_rate for s in summaries] == pytest.approx([1e-3] * 5)


def test_the_latest_rollback_is_said_with_how_many_there_were() -> None:
    one = {"rollback_to": 2.0, "best_lap_time": 8.0, "next_learning_rate": 5e-4, "lr_factor": 0.5}
    two = {"rollback_to": 9.0, "best_lap_time": 7.5, "next_learning_rate": 2.5e-4, "lr_factor": 0.25}
    assert latest_rollback([(0, {"lr_factor": 1.0}), (1, None)]) is None
    assert latest_rollback([(5, one), (6, {"lr_factor": 0.5})]) == rollback_message(5, 2, 8.0, 5e-4)
    latest = rollback_message(12, 9, 7.5, 2.5e-4) + " (2 rollbacks so far)"
    assert latest_rollback([(5, one), (12, two)]) == latest


def test_a_long_sentence_wraps_after_its_semicolon_then_at_the_width() -> None:
    text = rollback_message(12345, 12000, 123.45, 9.375e-6)
    lines = wrap(text, 70)
    assert all(len(line) <= 70 for line in lines) and any(line.endswith(";") for line in lines)
    assert all(line.startswith("  ") for line in lines[1:])
    assert " ".join(" ".join(lines).split()) == text
