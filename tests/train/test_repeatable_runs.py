"""Runs that repeat (issue 40, item 4): two runs with the same ``--seed`` on the same machine drive the
same training episodes and the same evaluations, and keep the same best checkpoint."""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path
from typing import Any

from drx.settings.hyperparameters import Hyperparameters
from drx.settings.stop import StopConditions
from drx.train.evaluation import evaluation_seed
from drx.train.policy_weights import load_policy_weights
from drx.train.records import CheckpointRecord, EpisodeRecord, IterationSummary, NullSink
from drx.train.trainer import Trainer, TrainingSpec

from .conftest import compact_car, real_env_factory

RUNS = ("first", "again")
RUN_ONLY = ("wall_seconds",)  # what may differ between two runs: how long an episode took here
CLOCKS = ("elapsed", "job_elapsed", "created")  # the best checkpoint's wall-clock figures


class Recorder(NullSink):
    """Every episode and checkpoint a run reports."""

    def __init__(self) -> None:
        self.episodes: list[dict[str, Any]] = []
        self.checkpoints: list[CheckpointRecord] = []

    def on_iteration(self, summary: IterationSummary, episodes: list[EpisodeRecord]) -> None:
        self.episodes += [{k: v for k, v in asdict(e).items() if k not in RUN_ONLY} for e in episodes]

    def on_checkpoint(self, record: CheckpointRecord) -> None:
        self.checkpoints.append(record)


def _run(folder: Path, seed: int) -> tuple[Recorder, dict[str, Any] | None]:
    """Two iterations of five episodes on the oval (two evaluation episodes after each)."""
    car = compact_car()
    spec = TrainingSpec(
        vehicle=car,
        hyperparameters=Hyperparameters(episodes_per_iteration=5),
        stop=StopConditions(max_minutes=None, max_episodes=10),
        folder=folder,
        env_factory=real_env_factory(Path("oval"), car),
        eval_episodes=2,
        seed=seed,
        threads=1,
    )
    sink = Recorder()
    result = Trainer(spec, sink).run()
    assert result.last_iteration == 1
    return sink, result.best


def test_the_same_seed_drives_the_same_episodes_evaluations_and_best(tmp_path: Path) -> None:
    first, best = _run(tmp_path / "first", seed=7)
    again, best_again = _run(tmp_path / "again", seed=7)
    evaluations = [e for e in first.episodes if e["phase"] == "evaluation"]
    assert len(evaluations) == 4 and len(first.episodes) == 14
    assert first.episodes == again.episodes  # training and evaluation episodes, step for step
    assert [(c.iteration, c.is_best) for c in first.checkpoints] == [
        (c.iteration, c.is_best) for c in again.checkpoints
    ]
    assert best is not None and best_again is not None
    assert {k: v for k, v in best.items() if k not in CLOCKS} == {
        k: v for k, v in best_again.items() if k not in CLOCKS
    }
    car = compact_car()
    kept = [load_policy_weights(tmp_path / run / "model" / "best.zip", car).state_dict() for run in RUNS]
    assert all((kept[0][k] == kept[1][k]).all() for k in kept[0])


def test_evaluation_seeds_are_the_run_s_own() -> None:
    """Each evaluation episode has its own seed, from the run's seed, the iteration and its index."""
    seeds = {evaluation_seed(7, it, k) for it in range(3) for k in range(3)}
    assert len(seeds) == 9
    assert evaluation_seed(7, 1, 2) == evaluation_seed(7, 1, 2) != evaluation_seed(8, 1, 2)
