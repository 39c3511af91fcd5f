"""Training on several tracks: episodes take the tracks in turn, each from its own round robin,
and the records keep each track's figures apart; the evaluation stays on the first track."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import pytest

from drx.settings.episodes import EpisodeSettings, TrainingTrack
from drx.settings.hyperparameters import Hyperparameters
from drx.settings.stop import StopConditions
from drx.sim.registration import ENV_ID, register_envs
from drx.sim.schedule import ScheduledEnv
from drx.train.records import EpisodeRecord, IterationSummary, NullSink
from drx.train.trainer import Trainer, TrainingSpec

from .conftest import compact_car

SETTINGS = EpisodeSettings(
    (TrainingTrack("oval", "ccw"), TrainingTrack("kidney", "ccw")), round_robin_advance=0.1
)


class Sink(NullSink):
    def __init__(self) -> None:
        self.episodes: list[EpisodeRecord] = []
        self.summaries: list[IterationSummary] = []

    def on_episode(self, record: EpisodeRecord) -> None:
        self.episodes.append(record)

    def on_iteration(self, summary: IterationSummary, episodes: list[EpisodeRecord]) -> None:
        self.summaries.append(summary)
        self.episodes += [r for r in episodes if r.phase == "evaluation"]


def _factory(car: object) -> object:
    """The env factory a job builds (``drx.queue.train_job.build_spec``), over oval and kidney."""
    register_envs()

    def track_env(mode: str, index: int, reverse: bool) -> gym.Env:
        name = SETTINGS.tracks[index].name
        return gym.make(ENV_ID, track=name, reverse=reverse, vehicle=car, mode=mode, disable_env_checker=True)

    def make(mode: str) -> gym.Env:
        if mode == "training":
            return ScheduledEnv(SETTINGS, lambda index, reverse: track_env(mode, index, reverse))
        return track_env(mode, 0, False)

    return make


@pytest.mark.parametrize("workers", [1, 2])
def test_episodes_alternate_tracks_and_the_records_keep_them_apart(tmp_path: Path, workers: int) -> None:
    car = compact_car()
    spec = TrainingSpec(
        vehicle=car,
        hyperparameters=Hyperparameters(episodes_per_iteration=6, num_epochs=3),
        stop=StopConditions(max_minutes=None, max_episodes=12),
        folder=tmp_path / "m",
        env_factory=_factory(car),  # type: ignore[arg-type]
        eval_episodes=1,
        seed=0,
        threads=1,
        rollout_workers=workers,
    )
    sink = Sink()
    result = Trainer(spec, sink).run()
    assert result.episodes == 12
    training = [r for r in sink.episodes if r.phase == "training"]
    assert [r.track for r in training] == ["oval", "kidney"] * 6
    # each track its own round robin: its k-th episode from k x 10% of the lap
    assert [round(r.start_fraction, 4) for r in training] == [k / 10 for k in range(6) for _ in range(2)]
    for summary in sink.summaries:
        assert list(summary.by_track) == ["oval", "kidney"]
        assert all(f.episodes == 3 for f in summary.by_track.values())
        mine = [r for r in training if r.iteration == summary.iteration and r.track == "kidney"]
        assert summary.by_track["kidney"].mean_progress == pytest.approx(sum(r.progress for r in mine) / 3)
    # the evaluation drives the model's first track (its env says no track: the model's own)
    assert [r.track for r in sink.episodes if r.phase == "evaluation"] == [None, None]


def test_sac_episodes_take_the_tracks_in_turn_too(tmp_path: Path) -> None:
    """SAC samples through SB3's own resets (no episode option): the schedule counts them."""
    car = compact_car(continuous=True)
    spec = TrainingSpec(
        vehicle=car,
        hyperparameters=Hyperparameters.default("sac").replace(batch_size=32),
        stop=StopConditions(max_minutes=None, max_episodes=4),
        folder=tmp_path / "m",
        env_factory=_factory(car),  # type: ignore[arg-type]
        eval_episodes=1,
        seed=0,
        threads=1,
    )
    sink = Sink()
    Trainer(spec, sink).run()
    training = [r for r in sink.episodes if r.phase == "training"]
    assert [r.track for r in training] == ["oval", "kidney", "oval", "kidney"]
    assert [round(r.start_fraction, 4) for r in training] == [0.0, 0.0, 0.1, 0.1]
