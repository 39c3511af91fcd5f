"""A model that trains on several tracks is shown whole (issue 40, item 5): ``drx analyze`` and
``drx plot`` give each track's figures apart, and no picture draws one track's episodes over another."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from drx.analysis.data import episode_table, load_run, load_training_trace, model_folder, trace_tracks
from drx.analysis.report import analyze_model
from drx.analysis.reward_graph import reward_graph
from drx.registry import dispose_engines

from ._cli import ok_json
from ._run import train_tiny
from .conftest import use_home

MODEL = "two-tracks"
TRACKS = ("oval", "Oval_track")


@pytest.fixture(scope="module")
def multi_home(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A data home holding a model trained 2 iterations of 5 episodes, the episodes taking the oval
    and DeepRacer's Oval_track in turn."""
    home = tmp_path_factory.mktemp("multi_home")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("DRX_HOME", str(home))
        mp.delenv("DRX_DATABASE_URL", raising=False)
        dispose_engines()
        try:
            train_tiny(MODEL, episodes=10, per_iteration=5, track=list(TRACKS))
        finally:
            dispose_engines()
    return home


@pytest.fixture
def multi(multi_home: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[str]:
    use_home(monkeypatch, multi_home)
    dispose_engines()
    yield MODEL
    dispose_engines()


def test_each_trace_row_is_given_the_track_its_episode_drove(multi: str) -> None:
    run = load_run(multi)
    assert run.training_tracks() == list(TRACKS)
    trace = load_training_trace(model_folder(multi))
    on = trace_tracks(trace, run.episodes)
    assert on.notna().all()
    registry = run.phase("training")
    for name in TRACKS:  # each track's trace episodes are its registry episodes, step for step
        episodes = episode_table(trace[on == name])
        mine = registry[registry["track_name"] == name]
        assert sorted(zip(episodes["iteration"], episodes["steps"], strict=True)) == sorted(
            zip(mine["iteration"], mine["steps"], strict=True)
        )
        assert np.allclose(sorted(episodes["reward"]), sorted(mine["reward"]), atol=1e-3)


def test_analyze_gives_each_track_s_figures_and_pictures(multi: str, tmp_path: Path) -> None:
    report = analyze_model(multi, out=tmp_path)
    assert [part.track for part in report.tracks] == list(TRACKS)
    assert report.pictures == {} and report.breakdown.empty  # nothing drawn over the wrong track
    assert sum(part.overall["episodes"] for part in report.tracks) == report.overall["episodes"] == 10
    for part in report.tracks:
        assert sorted(part.pictures) == ["actions", "heatmaps", "paths"]
        assert all(path.is_file() and part.track in path.name for path in part.pictures.values())
        assert not part.breakdown.empty and not part.best.empty
        has_evaluations = part.table["eval_episodes"].sum() > 0
        assert has_evaluations == (part.track == TRACKS[0])  # the evaluation drives the first track
    data = ok_json("analyze", multi, "--out", str(tmp_path / "cli"))
    assert [t["track"] for t in data["tracks"]] == list(TRACKS)
    assert data["pictures"] == {}


def test_plot_draws_a_training_line_per_track(multi: str) -> None:
    run = load_run(multi)
    fig = reward_graph([run])
    ax_reward = fig.axes[0]
    lines = {line.get_label(): line for line in ax_reward.get_lines()}
    train = run.phase("training")
    for name in TRACKS:
        line = lines[f"{multi} training on {name}"]
        expected = train[train["track_name"] == name].groupby("iteration")["reward"].mean()
        assert np.allclose(line.get_ydata(), expected.to_numpy())
    assert f"{multi} training" not in lines  # no line averaging tracks of different lengths
    assert f"{multi} evaluation on {TRACKS[0]}" in lines
