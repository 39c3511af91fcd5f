"""Time limits that hold whatever the network, and the phases a run reports."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from drx.settings.stop import StopConditions
from drx.train import trainer as trainer_module
from drx.train.checkpoint import checkpoint_path, read_meta
from drx.train.records import EVALUATING, SAMPLING, SAVING, NullSink, updating
from drx.train.stop import MAX_MINUTES, StopWatch
from drx.train.trainer import Trainer

from .conftest import SpecFactory


class PhaseSink(NullSink):
    """Keeps the phases; sleeps once on entering ``slow_phase`` (a stand-in for a slow update)."""

    def __init__(self, slow_phase: str | None = None, sleep: float = 0.0) -> None:
        self.phases: list[tuple[str, float]] = []
        self.slow_phase, self.sleep = slow_phase, sleep

    def on_phase(self, phase: str, elapsed: float) -> None:
        self.phases.append((phase, elapsed))
        if phase == self.slow_phase:
            self.slow_phase = None
            time.sleep(self.sleep)


def test_phases_of_an_iteration_in_order(corridor_spec: SpecFactory) -> None:
    sink = PhaseSink()
    spec = corridor_spec(stop=StopConditions(max_minutes=None, max_episodes=5), num_epochs=3)
    Trainer(spec, sink).run()
    names = [p for p, _ in sink.phases]
    assert names == [SAMPLING, updating(1, 3), updating(2, 3), updating(3, 3), EVALUATING, SAVING]
    elapsed = [e for _, e in sink.phases]
    assert elapsed == sorted(elapsed) and elapsed[0] >= 0.0


def test_update_is_cut_between_minibatches_at_the_time_limit(
    corridor_spec: SpecFactory, tmp_path: Path
) -> None:
    """The limit comes during the update (one slow minibatch): the update ends at the next
    minibatch, the evaluation is skipped and the checkpoint is still written."""
    limit_s = 6.0
    sink = PhaseSink(slow_phase=updating(1, 10), sleep=limit_s + 0.5)
    spec = corridor_spec(stop=StopConditions(max_minutes=limit_s / 60, max_episodes=None), num_epochs=10)
    started = time.monotonic()
    result = Trainer(spec, sink).run()
    wall = time.monotonic() - started
    assert result.stop_reason == MAX_MINUTES
    assert result.iterations == 1 and result.summaries[0].extra.get("update_cut") == 1.0
    names = [p for p, _ in sink.phases]
    assert updating(2, 10) not in names and EVALUATING not in names and names[-1] == SAVING
    assert result.summaries[0].eval_episodes == 0
    meta = read_meta(checkpoint_path(spec.folder, "last"))
    assert meta["iteration"] == 0 and meta["evaluated"] is False
    assert checkpoint_path(spec.folder, "best").is_file()  # the only checkpoint is also the best
    assert wall <= limit_s + StopWatch(spec.stop).overshoot_allowed()  # type: ignore[operator]


def test_update_started_past_the_limit_gets_half_the_overshoot(corridor_spec: SpecFactory) -> None:
    """Sampling ran to the limit: the update may use half the allowed overshoot, then stops."""
    watch = StopWatch(StopConditions(max_minutes=1.0))
    assert watch.overshoot_allowed() == 20.0  # 10% of 60 s is less than 20 s
    assert StopWatch(StopConditions(max_minutes=10.0)).overshoot_allowed() == 60.0
    assert StopWatch(StopConditions(max_minutes=None)).overshoot_allowed() is None
    watch.start(time.monotonic() - 61.0)  # the job started 61 s ago: 1 s past the limit
    assert watch.past_limit() and not watch.past_limit(10.0) and watch.past_limit(0.5)


def test_elapsed_counts_from_the_job_start(corridor_spec: SpecFactory) -> None:
    """Time spent before the trainer was built (queue, model set-up) counts toward max_minutes."""
    spec = corridor_spec(stop=StopConditions(max_minutes=1.0, max_episodes=None))
    spec.started = time.monotonic() - 61.0
    result = Trainer(spec).run()
    assert result.stop_reason == MAX_MINUTES and result.iterations == 0


class StopAtUpdate(NullSink):
    """Asks the run to stop when the update starts (as the first Ctrl-C does)."""

    def __init__(self) -> None:
        self.asked = False
        self.phases: list[str] = []

    def on_phase(self, phase: str, elapsed: float) -> None:
        self.phases.append(phase)
        if phase == updating(1, 10):
            self.asked = True

    def stop_requested(self) -> bool:
        return self.asked


def test_a_stop_request_ends_the_update_soon_and_keeps_a_checkpoint(
    corridor_spec: SpecFactory, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(trainer_module, "OVERSHOOT_SECONDS", 0.0)  # end at the next minibatch
    sink = StopAtUpdate()
    spec = corridor_spec(stop=StopConditions(max_minutes=None, max_episodes=None), num_epochs=10)
    result = Trainer(spec, sink).run()
    assert result.stop_reason == "requested" and result.iterations == 1
    assert result.summaries[0].extra.get("update_cut") == 1.0
    assert updating(2, 10) not in sink.phases and EVALUATING not in sink.phases
    assert read_meta(checkpoint_path(spec.folder, "last"))["iteration"] == 0
