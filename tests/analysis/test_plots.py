"""``drx plot`` and ``drx analyze`` on a real short training run: readable PNGs, tables, bad input."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from matplotlib.image import imread

from drx.analysis.actions import track_sections
from drx.analysis.data import load_run, load_training_trace, model_folder
from drx.analysis.report import analyze_model
from drx.analysis.reward_graph import reward_graph
from drx.registry import Episode, session_scope
from drx.services import models as model_service
from drx.sim.track import load_track

from ._cli import fails_unchanged, invoke, ok_json


def assert_picture(path: Path, min_size: tuple[int, int] = (600, 300)) -> np.ndarray:
    """A PNG a person can read: at least ``min_size`` pixels (w, h), and not one flat colour."""
    assert path.is_file() and path.stat().st_size > 10_000, path
    img = imread(path)
    h, w = img.shape[:2]
    assert w >= min_size[0] and h >= min_size[1], (path, w, h)
    assert float(img[..., :3].std()) > 0.05, f"{path} looks blank"
    return img


def test_reward_graph_png(trained: str, tmp_path: Path) -> None:
    data = ok_json("plot", trained, "--out", tmp_path / "graph.png")
    img = assert_picture(Path(data["png"]), (1000, 700))
    assert img.shape[1] == 1430  # 13 in x 110 dpi
    (summary,) = data["models"]
    run = load_run(trained)
    assert summary["training_episodes"] == len(run.phase("training")) == 15
    assert summary["iterations"] == 3
    assert summary["best_iteration"] == run.best_iteration is not None


def test_reward_graph_axes_have_data(trained: str) -> None:
    fig = reward_graph([load_run(trained)])
    ax_reward, ax_progress = fig.axes
    for ax in (ax_reward, ax_progress):
        assert ax.collections, "no episode dots"
        lines = [ln for ln in ax.get_lines() if len(ln.get_xdata()) > 1]
        assert lines, "no average line"
        assert ax.get_xlabel() or ax is ax_reward
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert any("best checkpoint" in t for t in labels)
    assert any("evaluation" in t for t in labels)


def _fake_history(name: str, parent: str, iterations: int = 4, per_iteration: int = 3) -> None:
    """A clone with registry episodes written through the registry's own tables."""
    model = model_service.clone_model(parent, name)
    rng = np.random.default_rng(3)
    with session_scope() as session:
        for it in range(iterations):
            for k in range(per_iteration):
                progress = float(min(100.0, 20 * it + rng.uniform(0, 30)))
                session.add(Episode(
                    model_id=model.id, iteration=it, episode=k, phase="training", reward=progress * 0.8,
                    progress=progress, steps=int(progress * 3) + 1,
                    status="lap_complete" if progress >= 100 else "off_track",
                ))  # fmt: skip


def test_several_models_on_one_chart(trained: str, tmp_path: Path) -> None:
    name = f"clone-{tmp_path.name[-12:].replace('_', '-')}"
    _fake_history(name, trained)
    try:
        data = ok_json("plot", trained, name, "--out", tmp_path / "both.png")
        assert_picture(Path(data["png"]))
        assert [m["model"] for m in data["models"]] == [trained, name]
        fig = reward_graph([load_run(trained), load_run(name)])
        labels = " ".join(t.get_text() for t in fig.legends[0].get_texts())
        assert trained in labels and name in labels
    finally:
        model_service.remove_model(name)


def test_plot_bad_input(trained: str, tmp_path: Path) -> None:
    fails_unchanged("plot", "no-such-model", contains="No model named")
    model_service.create_model(f"draft-{tmp_path.name[-8:].replace('_', '-')}")
    draft = model_service.list_models()[-1].name
    try:
        fails_unchanged("plot", draft, "--out", tmp_path / "x.png", contains="no episodes")
        fails_unchanged("plot", trained, "--out", tmp_path / "x.jpg", contains=".png")
    finally:
        model_service.remove_model(draft)


def test_analyze_writes_pictures_and_table(trained: str, tmp_path: Path) -> None:
    data = ok_json("analyze", trained, "--out", tmp_path)
    assert set(data["pictures"]) == {"paths", "heatmaps", "actions"}
    for path in data["pictures"].values():
        assert Path(path).parent == tmp_path
        assert_picture(Path(path))
    assert [row["iteration"] for row in data["table"]] == [0, 1, 2]
    assert all(row["episodes"] == 5 for row in data["table"])
    assert all(0 <= row["completion_rate"] <= 100 for row in data["table"])
    run = load_run(trained)
    train = run.phase("training")
    for row in data["table"]:
        expected = train[train["iteration"] == row["iteration"]]["progress"].mean()
        assert row["mean_progress"] == pytest.approx(expected)
    assert 1 <= len(data["best_episodes"]) <= 5
    best = data["best_episodes"][0]["progress"]
    assert best == pytest.approx(max(r["progress"] for r in data["best_episodes"]))
    shares = data["actions_per_section"]
    visited = [s for s in shares.values() if sum(s.values()) > 0]
    assert visited and all(sum(s.values()) == pytest.approx(100.0, abs=0.1) for s in visited)


def test_analyze_one_iteration(trained: str, tmp_path: Path) -> None:
    report = analyze_model(trained, iteration=1, out=tmp_path)
    assert report.iterations == [1]
    assert list(report.table["iteration"]) == [1]
    assert set(report.best["iteration"]) == {1}
    assert all(p.name.startswith(f"{trained}-iteration-1-") for p in report.pictures.values())


def test_analyze_bad_input(trained: str, tmp_path: Path) -> None:
    fails_unchanged("analyze", trained, "--iteration", 99, "--out", tmp_path, contains="iteration 99")
    fails_unchanged("analyze", trained, "--iteration", -1, "--out", tmp_path, contains="-1")
    fails_unchanged("analyze", "nobody", contains="No model named")


def test_trace_matches_registry_steps(trained: str) -> None:
    trace = load_training_trace(model_folder(trained))
    run = load_run(trained)
    per_episode = trace.groupby("episode")["steps"].count().to_numpy()
    assert list(per_episode) == list(run.phase("training")["steps"])


@pytest.mark.parametrize("name", ["oval", "kidney", "hairpin", "technical"])
def test_sections_cover_the_lap(name: str) -> None:
    track = load_track(name)
    sections = track_sections(track)
    assert sections[0].contains(np.array([0.0]), track.length)[0], "S1 holds the start line"
    s = np.linspace(0, track.length, 2000, endpoint=False)
    counts = sum(sec.contains(s, track.length).astype(int) for sec in sections)
    assert (counts == 1).all(), "every point of the lap lies in exactly one section"
    turns = [sec for sec in sections if sec.kind != "straight"]
    assert turns
    if name == "oval":
        assert [sec.kind for sec in sections] == ["straight", "left turn", "straight", "left turn"]


def test_one_iteration_is_drawn_on_whole_iterations_and_said(trained: str, tmp_path: Path) -> None:
    """Issue 14: one iteration drew a -0.3..0.3 axis; a model with no episodes vanished silently."""
    name = f"one-{tmp_path.name[-8:].replace('_', '-')}"
    _fake_history(name, trained, iterations=1)
    draft = f"draft-{tmp_path.name[-8:].replace('_', '-')}"
    model_service.create_model(draft)
    try:
        fig = reward_graph([load_run(name), load_run(draft)])
        ax_reward, ax_progress = fig.axes
        low, high = ax_progress.get_xlim()
        assert low <= -0.5 and high >= 1.5
        ticks = [t for t in ax_progress.get_xticks() if low <= t <= high]
        assert ticks and all(float(t).is_integer() for t in ticks)
        title = fig.get_suptitle()
        assert f"{name}: oval, PPO, 1 iteration so far" in title
        assert f"{draft}: no episodes yet, nothing drawn" in title
        result = invoke("plot", name, draft, "--out", tmp_path / "both.png")
        assert result.exit_code == 0, result.output
        assert f"Warning: model {draft} has no episodes yet" in result.stderr
    finally:
        model_service.remove_model(name)
        model_service.remove_model(draft)


def test_analyze_bar_names_are_readable_with_a_key(trained: str) -> None:
    from drx.analysis.actions import TICK_FONT, breakdown_figure
    from drx.analysis.data import load_training_trace
    from drx.services.models import get_model

    model = get_model(trained)
    trace = load_training_trace(model_folder(trained))
    fig = breakdown_figure(load_track(model.track_name), model.vehicle(), trace, trained)
    charts = [ax for ax in fig.axes if ax.get_ylabel() == "% of steps"]
    assert charts
    for ax in charts:
        labels = ax.get_xticklabels()
        assert [t.get_text() for t in labels] == [f"#{i}" for i in range(model.vehicle().n_actions)]
        assert all(t.get_fontsize() >= TICK_FONT for t in labels)
    key = " ".join(t.get_text() for ax in fig.axes for t in ax.texts)
    first = model.vehicle().actions[0]
    assert f"#0 {first.steering_angle:g}°/{first.speed:g}" in key
