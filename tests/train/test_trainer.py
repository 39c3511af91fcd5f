"""The training loop on the dummy corridor env: iterations, stop conditions, checkpoints, resume, clones."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from drx.settings.stop import StopConditions
from drx.train.checkpoint import checkpoint_path, is_better, read_meta
from drx.train.evaluation import policy_outputs
from drx.train.records import CheckpointRecord, EpisodeRecord, IterationSummary, NullSink
from drx.train.trainer import Trainer

from .conftest import SpecFactory, compact_car


class ListSink(NullSink):
    """Keeps everything; can ask for a stop after some episodes."""

    def __init__(self, stop_after_episodes: int | None = None) -> None:
        self.episodes: list[EpisodeRecord] = []
        self.iterations: list[IterationSummary] = []
        self.checkpoints: list[CheckpointRecord] = []
        self.discarded: list[int] = []
        self.stop_after = stop_after_episodes

    def on_episode(self, record: EpisodeRecord) -> None:
        self.episodes.append(record)

    def on_iteration(self, summary: IterationSummary, episodes: list[EpisodeRecord]) -> None:
        self.iterations.append(summary)

    def on_checkpoint(self, record: CheckpointRecord) -> None:
        self.checkpoints.append(record)

    def on_discard(self, iteration: int) -> None:
        self.discarded.append(iteration)

    def stop_requested(self) -> bool:
        return self.stop_after is not None and len(self.episodes) >= self.stop_after


def test_iterations_are_whole_episodes(corridor_spec: SpecFactory) -> None:
    spec = corridor_spec(stop=StopConditions(max_minutes=None, max_episodes=10))
    sink = ListSink()
    result = Trainer(spec, sink).run()
    assert result.stop_reason == "max_episodes" and result.episodes == 10 and result.last_iteration == 1
    assert [s.episodes for s in sink.iterations] == [5, 10]
    train = [e for e in sink.episodes if e.phase == "training"]
    assert [e.iteration for e in train] == [0] * 5 + [1] * 5 and [e.episode for e in train[:5]] == list(
        range(5)
    )
    assert sum(e.steps for e in train) == result.steps
    assert all(s.policy_loss is not None and s.entropy is not None for s in sink.iterations)
    folder = spec.folder
    assert (folder / "model" / "model_metadata.json").is_file() and (
        folder / "ip" / "hyperparameters.json"
    ).is_file()
    assert sorted(p.name for p in (folder / "training-simtrace").iterdir()) == [
        "0-iteration.csv",
        "1-iteration.csv",
    ]
    meta = read_meta(checkpoint_path(folder, "last"))
    assert meta["iteration"] == 1 and meta["episodes"] == 10 and meta["steps"] == result.steps
    assert not list((folder / "model").glob(".*tmp*"))  # no temporary file left behind


def test_max_steps_cuts_mid_episode_and_keeps_whole_episodes(corridor_spec: SpecFactory) -> None:
    spec = corridor_spec(stop=StopConditions(max_minutes=None, max_steps=150))
    result = Trainer(spec, ListSink()).run()
    assert result.stop_reason == "max_steps" and result.steps == 150


def test_target_stops_after_k_perfect_evaluations(corridor_spec: SpecFactory) -> None:
    # The corridor's evaluation starts centred with no wind from the side on even episodes; a
    # trained policy laps quickly, an untrained one sometimes does. Allow plenty of iterations.
    spec = corridor_spec(stop=StopConditions(max_minutes=None, max_episodes=400, target_iterations=2))
    sink = ListSink()
    result = Trainer(spec, sink).run()
    assert result.stop_reason == "target" and len(sink.iterations) >= 2
    last_two = sink.iterations[-2:]
    assert all(s.eval_laps_complete == s.eval_episodes == 2 for s in last_two)


def test_max_minutes(corridor_spec: SpecFactory) -> None:
    spec = corridor_spec(stop=StopConditions(max_minutes=0.001))
    result = Trainer(spec, ListSink()).run()
    assert result.stop_reason == "max_minutes" and result.iterations <= 1


def test_stop_request_mid_iteration_still_checkpoints(corridor_spec: SpecFactory) -> None:
    spec = corridor_spec(stop=StopConditions(max_minutes=None, max_episodes=100))
    sink = ListSink(stop_after_episodes=3)
    result = Trainer(spec, sink).run()
    assert result.stop_reason == "requested" and result.last_iteration == 0
    assert sink.checkpoints and sink.checkpoints[-1].iteration == 0


def test_resume_continues_numbering_and_limits(corridor_spec: SpecFactory, tmp_path: Path) -> None:
    folder = tmp_path / "m"
    spec = corridor_spec(folder=folder, stop=StopConditions(max_minutes=None, max_episodes=5))
    spec.run_key = "job-1"
    Trainer(spec, ListSink()).run()
    stale = folder / "model" / ".last.abc123.tmp.zip"  # what a kill -9 during a save leaves
    stale.write_bytes(b"half a zip")
    # Same job again (a resumed attempt): its 5 episodes count, so it stops at once.
    again = Trainer(spec, ListSink()).run()
    assert again.iterations == 0 and again.stop_reason == "max_episodes"
    assert not stale.exists()
    # A new job on the same model continues from the checkpoint with fresh limits.
    spec2 = corridor_spec(folder=folder, stop=StopConditions(max_minutes=None, max_episodes=5))
    spec2.run_key = "job-2"
    sink = ListSink()
    result = Trainer(spec2, sink).run()
    assert result.last_iteration == 1 and result.episodes == 10
    assert sink.episodes[0].iteration == 1 and sink.episodes[0].global_episode == 5


def test_clone_starts_with_the_parents_policy(corridor_spec: SpecFactory, tmp_path: Path) -> None:
    parent = corridor_spec(folder=tmp_path / "parent", stop=StopConditions(max_minutes=None, max_episodes=5))
    parent_trainer = Trainer(parent, ListSink())
    parent_trainer.run()
    best = checkpoint_path(parent.folder, "best")
    clone = corridor_spec(folder=tmp_path / "clone", stop=StopConditions(max_minutes=None, max_episodes=5))
    clone.init_checkpoint = best
    clone.seed = 99
    clone_trainer = Trainer(clone, ListSink())
    frames = np.random.default_rng(0).integers(0, 256, (4, 120, 160, 1), dtype=np.uint8)
    parent_trainer.model.set_parameters(str(best))
    assert np.allclose(
        policy_outputs(clone_trainer.model, frames), policy_outputs(parent_trainer.model, frames)
    )
    fresh = Trainer(corridor_spec(folder=tmp_path / "fresh"), ListSink())
    assert not np.allclose(policy_outputs(fresh.model, frames), policy_outputs(parent_trainer.model, frames))


@pytest.mark.parametrize("loss", ["huber", "mse"])
def test_continuous_ppo_and_sac(corridor_spec: SpecFactory, loss: str, tmp_path: Path) -> None:
    car = compact_car(continuous=True)
    ppo = corridor_spec(
        folder=tmp_path / "ppo",
        car=car,
        loss_type=loss,
        stop=StopConditions(max_minutes=None, max_episodes=5),
    )
    assert Trainer(ppo, ListSink()).run().iterations == 1
    sac = corridor_spec(
        folder=tmp_path / "sac", car=car, algorithm="sac", loss_type=loss, episodes_per_iteration=2,
        stop=StopConditions(max_minutes=None, max_episodes=4),
    )  # fmt: skip
    sink = ListSink()
    assert Trainer(sac, sink).run().iterations == 2
    assert sink.iterations[-1].value_loss is not None


def test_camera_and_lidar(corridor_spec: SpecFactory) -> None:
    spec = corridor_spec(car=compact_car(lidar=True), stop=StopConditions(max_minutes=None, max_episodes=5))
    assert Trainer(spec, ListSink()).run().iterations == 1


def test_best_is_progress_then_lap_time() -> None:
    assert is_better(50.0, None, None)
    assert is_better(60.0, None, {"eval_progress": 50.0})
    assert not is_better(40.0, 9.0, {"eval_progress": 50.0})
    assert is_better(100.0, 9.0, {"eval_progress": 100.0, "eval_lap_time": 10.0})
    assert not is_better(100.0, 11.0, {"eval_progress": 100.0, "eval_lap_time": 10.0})
    assert is_better(100.0, 11.0, {"eval_progress": 100.0, "eval_lap_time": None})
