"""Rollout workers: episodes sampled by K processes, handed on as one worker would hand them."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

from drx.errors import DrxError
from drx.settings.hyperparameters import Hyperparameters
from drx.settings.stop import StopConditions
from drx.sim.env import ROUND_ROBIN_STEP
from drx.train.algorithms import build_algorithm
from drx.train.records import EpisodeRecord, NullSink
from drx.train.rollout import (
    RolloutWorkers,
    default_rollout_workers,
    episode_seeds,
    slim_info,
    start_fraction,
)
from drx.train.trace import closest_waypoint
from drx.train.trainer import Trainer, TrainingSpec

from .conftest import compact_car, real_env_factory


class EpisodeSink(NullSink):
    def __init__(self) -> None:
        self.episodes: list[EpisodeRecord] = []

    def on_episode(self, record: EpisodeRecord) -> None:
        self.episodes.append(record)


def _train(
    folder: Path, workers: int, episodes: int = 12, steps: int | None = None
) -> tuple[list[EpisodeRecord], Path]:
    car = compact_car()
    spec = TrainingSpec(
        vehicle=car,
        hyperparameters=Hyperparameters(episodes_per_iteration=6, num_epochs=3),
        stop=StopConditions(max_minutes=None, max_episodes=episodes, max_steps=steps),
        folder=folder,
        env_factory=real_env_factory(Path("oval"), car),
        eval_episodes=1,
        seed=0,
        threads=1,
        rollout_workers=workers,
    )
    sink = EpisodeSink()
    result = Trainer(spec, sink).run()
    if steps is None:
        assert result.stop_reason == "max_episodes" and result.episodes == episodes
    else:
        assert result.stop_reason == "max_steps" and result.steps == steps
    return sink.episodes, folder / "training-simtrace"


def _trace(folder: Path, iteration: int) -> list[dict[str, str]]:
    with (folder / f"{iteration}-iteration.csv").open() as f:
        return list(csv.DictReader(f))


@pytest.mark.parametrize("workers", [1, 3])
def test_episodes_and_trace_are_those_of_one_worker(tmp_path: Path, workers: int) -> None:
    """Episode numbers run on without gaps, each starts where DeepRacer's round robin puts it,
    and the trace lists the episodes in order, steps counting up, times rising."""
    records, traces = _train(tmp_path / "m", workers)
    assert [(r.iteration, r.episode, r.global_episode) for r in records] == [
        (g // 6, g % 6, g) for g in range(12)
    ]
    for r in records:
        assert r.start_fraction == pytest.approx(start_fraction(r.global_episode), abs=1e-6)
    for iteration in (0, 1):
        rows = _trace(traces, iteration)
        episodes = [int(row["episode"]) for row in rows]
        assert episodes == sorted(episodes) and set(episodes) == set(range(6 * iteration, 6 * iteration + 6))
        stamps = [float(row["tstamp"]) for row in rows]
        assert stamps == sorted(stamps)
        for g in set(episodes):
            steps = [int(row["steps"]) for row in rows if int(row["episode"]) == g]
            assert steps == list(range(1, len(steps) + 1))
            assert [row["done"] for row in rows if int(row["episode"]) == g][-1] == "True"
        by_episode = {r.global_episode: r for r in records}
        for g in set(episodes):
            assert by_episode[g].steps == sum(1 for e in episodes if e == g)


@pytest.mark.parametrize(("counts", "steps"), [((1, 2), None), ((1, 3), 230)])
def test_a_seeded_run_is_the_same_whatever_the_worker_count(
    tmp_path: Path, counts: tuple[int, int], steps: int | None
) -> None:
    """Episode g is seeded from (seed, g) whichever worker drives it (one worker drives it in the
    trainer's process), and handed on in order: any number of workers writes the same episode rows
    and byte-identical traces, whole iterations or cut by a step limit in the middle of an
    episode of the first iteration."""
    two, traces_two = _train(tmp_path / "two", counts[0], steps=steps)
    three, traces_three = _train(tmp_path / "three", counts[1], steps=steps)
    assert [r.global_episode for r in two] == list(range(len(two)))
    assert [(r.global_episode, r.steps, r.reward, r.progress, r.status) for r in two] == [
        (r.global_episode, r.steps, r.reward, r.progress, r.status) for r in three
    ]
    files = sorted(p.name for p in traces_two.glob("*-iteration.csv"))
    assert files == sorted(p.name for p in traces_three.glob("*-iteration.csv"))
    assert files == (["0-iteration.csv", "1-iteration.csv"] if steps is None else ["0-iteration.csv"])
    for name in files:
        assert (traces_two / name).read_bytes() == (traces_three / name).read_bytes()
    if steps is not None:  # the cut episode's steps are in the trace, not in the episode rows
        assert len(_trace(traces_two, 0)) == steps > sum(r.steps for r in two)


def test_stopped_sampling_leaves_the_workers_ready_for_the_next_iteration() -> None:
    """A stop while the workers drive drops their episodes; the next collection starts clean."""
    car = compact_car()
    factory = real_env_factory(Path("oval"), car)
    model = build_algorithm(factory("training"), "compact", Hyperparameters(), seed=0)
    workers = RolloutWorkers(factory, 2, seed=0)
    try:
        workers.set_policy(model.policy, model.gamma)
        cut = model.collect_episodes_parallel(workers, 4, 0, keep_going=lambda: False)
        assert cut.interrupted and not workers.busy
        whole = model.collect_episodes_parallel(workers, 3, 0)
        assert (whole.episodes, whole.interrupted) == (3, False)
        assert whole.buffered_steps == model.rollout_buffer.pos > 0
        assert model.rollout_buffer.episode_starts[0] == 1
    finally:
        workers.close()


def test_episode_seeds_depend_on_seed_and_episode_only() -> None:
    assert episode_seeds(0, 5) == episode_seeds(0, 5)
    assert len({episode_seeds(s, g) for s in (0, 1) for g in (0, 1, 2)}) == 6


def test_start_fraction_is_the_envs_round_robin() -> None:
    assert [start_fraction(g) for g in (0, 1, 19, 20, 21)] == pytest.approx(
        [0.0, ROUND_ROBIN_STEP, 19 * ROUND_ROBIN_STEP, 0.0, ROUND_ROBIN_STEP]
    )


def test_slim_info_keeps_the_traces_closest_waypoint() -> None:
    waypoints = [(0.0, 0.0), (1.0, 0.0), (2.0, 0.0)]
    info = {
        "params": {"x": 1.2, "y": 0.1, "closest_waypoints": [1, 2], "waypoints": waypoints},
        "progress": 3.0,
    }
    slim = slim_info(info)
    assert "waypoints" not in slim["params"] and "waypoints" in info["params"]
    assert closest_waypoint(slim["params"]) == closest_waypoint(info["params"]) == 1


def test_a_failing_worker_reports_its_error() -> None:
    workers = RolloutWorkers(_broken_env, 2)
    try:
        with pytest.raises(ValueError, match="no env here"):
            workers.start(0, 0)
            workers.finished(timeout=60)
    finally:
        workers.close()


def _broken_env(mode: str) -> object:
    raise ValueError(f"no env here ({mode})")


def test_default_and_bad_counts() -> None:
    assert default_rollout_workers(1) == 1 and default_rollout_workers(2) == 1
    assert default_rollout_workers(8) == 4 and default_rollout_workers(64) == 8
    with pytest.raises(DrxError, match="2 or more"):
        RolloutWorkers(_broken_env, 1)
