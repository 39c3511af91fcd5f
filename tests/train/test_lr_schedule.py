"""``lr_schedule``: a learning rate that falls to zero at the run's end, from its start or from halfway."""

from __future__ import annotations

import pytest

from drx.settings.stop import StopConditions
from drx.train.stop import StopWatch
from drx.train.trainer import Trainer

from .conftest import SpecFactory, compact_car


def test_progress_is_the_nearest_limits_share() -> None:
    limits = StopConditions(max_minutes=None, max_steps=1000, max_episodes=40)
    watch = StopWatch(limits, steps=250, episodes=20)
    assert watch.progress() == pytest.approx(0.5)  # episodes: 20 of 40, nearer than steps' 250 of 1000
    watch.steps = 5000
    assert watch.progress() == 1.0  # capped: an update past the limit runs at the schedule's end


def test_progress_counts_the_minutes_of_earlier_attempts() -> None:
    watch = StopWatch(StopConditions(max_minutes=10.0), elapsed=150.0)
    assert watch.progress() == pytest.approx(0.25, abs=0.01)


def test_no_foreseeable_limit_has_no_progress() -> None:
    assert StopWatch(StopConditions(max_minutes=None, target_iterations=5)).progress() is None


@pytest.mark.parametrize("algorithm", ["ppo", "sac"])
def test_linear_schedule_falls_to_zero_over_the_run(corridor_spec: SpecFactory, algorithm: str) -> None:
    """Each update's rate is ``learning_rate`` x the share of the run still to go (or constant)."""
    car = compact_car(continuous=algorithm == "sac")
    per_iteration = 5 if algorithm == "ppo" else 1  # the fewest each algorithm allows
    stop = StopConditions(max_minutes=None, max_episodes=4 * per_iteration)
    rates = {}
    for schedule in ("constant", "linear", "settle"):
        spec = corridor_spec(stop=stop, car=car, algorithm=algorithm, lr_schedule=schedule,
                             learning_rate=1e-3, episodes_per_iteration=per_iteration)  # fmt: skip
        spec.folder = spec.folder.with_name(f"{algorithm}-{schedule}")
        rates[schedule] = [s.learning_rate for s in Trainer(spec).run().summaries]
    assert rates["constant"] == pytest.approx([1e-3] * 4)
    # four updates, after a quarter, a half, three quarters and all of the run's episodes
    assert rates["linear"] == pytest.approx([7.5e-4, 5e-4, 2.5e-4, 0.0])
    assert rates["settle"] == pytest.approx([1e-3, 1e-3, 5e-4, 0.0])
