"""Plain progress lines and the heartbeat, and the dashboard's live clock."""

from __future__ import annotations

import io
import time

from rich.console import Console

from drx.cli.dashboard import DashboardData, LiveSink, render
from drx.cli.progress import PlainProgress, clock
from drx.settings.stop import StopConditions
from drx.train.records import SAMPLING, IterationSummary, updating


def _summary(iteration: int = 0) -> IterationSummary:
    return IterationSummary(
        iteration=iteration, steps=1120, episodes=20, elapsed_seconds=50.0, steps_per_second=22.4,
        train_mean_reward=12.3, train_mean_progress=40.0, eval_mean_reward=30.0, eval_mean_progress=55.0,
        eval_laps_complete=1, eval_episodes=3,
    )  # fmt: skip


def test_heartbeat_during_a_long_phase() -> None:
    out = io.StringIO()
    with PlainProgress(out, StopConditions(max_minutes=10.0), heartbeat=0.3) as progress:
        progress.on_phase(updating(3, 10), 125.0)
        time.sleep(1.0)
    lines = out.getvalue().splitlines()
    assert len(lines) >= 2, lines  # at least one line per heartbeat interval
    assert all(updating(3, 10) in line for line in lines)
    assert lines[0].startswith("[0:02:05] ") and "left 0:07:5" in lines[0]


def test_one_line_per_iteration() -> None:
    out = io.StringIO()
    progress = PlainProgress(out, StopConditions(max_minutes=None), heartbeat=60.0)
    progress.on_phase(SAMPLING, 50.0)
    progress.on_iteration(_summary(), [])
    summary = _summary(1)
    summary.eval_episodes, summary.extra = 0, {"update_cut": 1.0}
    progress.on_iteration(summary, [])
    first, second = out.getvalue().splitlines()
    assert "iteration 0 done: 1120 steps, 20 episodes, 22 steps/s" in first
    assert "eval progress 55%, 1/3 laps" in first and "left" not in first
    assert "not evaluated" in second and "update cut" in second
    assert clock(3725) == "1:02:05" and clock(None) == "-"


def test_a_collapse_is_said_once_in_the_lines_and_on_the_dashboard() -> None:
    out = io.StringIO()
    progress = PlainProgress(out, StopConditions(max_minutes=None), heartbeat=60.0, model="fast")
    data = DashboardData(title="t", stop=StopConditions(max_minutes=None), model="fast")
    sink = LiveSink(data)
    for iteration, percent in enumerate([100.0, 100.0] + [5.0] * 15):
        summary = _summary(iteration)
        summary.eval_mean_progress = percent
        progress.on_iteration(summary, [])
        sink.on_iteration(summary, [])
    warnings = [line for line in out.getvalue().splitlines() if "warning: Training has collapsed" in line]
    assert len(warnings) == 1 and "drx model clone fast fast-2" in warnings[0]
    console = Console(width=80, record=True)
    console.print(render(data))
    assert "Training has collapsed" in console.export_text()


def test_dashboard_clock_runs_between_reports_and_shows_the_phase() -> None:
    data = DashboardData(title="t", stop=StopConditions(max_minutes=2.0))
    sink = LiveSink(data)
    sink.on_phase(updating(3, 10), 19.0)
    time.sleep(1.1)
    assert 20.0 <= data.elapsed_now() < 25.0  # wall time since the job started, running on
    text = _text(render(data))
    assert "updating the policy: epoch 3/10" in text and "0:00:2" in text and "0:01:" in text
    data.finished, data.elapsed = True, 30.0
    assert data.elapsed_now() == 30.0


def _text(renderable: object) -> str:
    from rich.console import Console

    console = Console(width=120, record=True, file=io.StringIO())
    console.print(renderable)
    return console.export_text()


def test_a_model_on_several_tracks_shows_each_tracks_figures() -> None:
    """The per-iteration line and the dashboard keep each track's training reward / progress apart."""
    from drx.train.records import TrackFigures

    summary = _summary()
    summary.by_track = {"oval": TrackFigures(10, 11.5, 35.0), "kidney": TrackFigures(10, 13.0, 45.0)}
    out = io.StringIO()
    PlainProgress(out, StopConditions(max_minutes=None), heartbeat=60.0).on_iteration(summary, [])
    assert "progress 40% (per track: oval 11.5 / 35%, kidney 13.0 / 45%), eval progress 55%" in out.getvalue()
    console = Console(file=io.StringIO(), width=120)
    data = DashboardData(title="t", stop=StopConditions(max_minutes=None), iterations=[summary])
    console.print(render(data))
    drawn = console.file.getvalue()
    assert "Per track (train reward / progress): oval 11.5 / 35%, kidney 13.0 / 45%" in drawn
    one = io.StringIO()
    PlainProgress(one, StopConditions(max_minutes=None), heartbeat=60.0).on_iteration(_summary(), [])
    assert "per track" not in one.getvalue()  # a one-track model's line is as it was


def test_the_lines_and_the_dashboard_name_the_device() -> None:
    """The plain lines (no terminal) say it once, first; the dashboard on its own line within 80 columns."""
    out = io.StringIO()
    with PlainProgress(
        out, StopConditions(max_minutes=None), heartbeat=60.0, device="cpu (torch 2.13.0+cpu)"
    ):
        pass
    assert out.getvalue().splitlines() == ["[0:00:00] training on cpu (torch 2.13.0+cpu)"]
    silent = io.StringIO()
    with PlainProgress(silent, StopConditions(max_minutes=None), heartbeat=60.0):
        pass
    assert silent.getvalue() == ""  # no device given (a caller that does not know it): no line
    gpu = "cuda:0 (NVIDIA GeForce RTX 4090 Laptop GPU)"
    data = DashboardData(
        title="t", stop=StopConditions(max_minutes=10.0), iterations=[_summary()], device=gpu
    )
    console = Console(width=80, record=True, file=io.StringIO())
    console.print(render(data))
    drawn = console.export_text().splitlines()
    assert any(f"Device: {gpu}" in line for line in drawn)
    assert max(len(line) for line in drawn) <= 80


ROLLBACK = {"lr_factor": 0.5, "rollback_to": 28.0, "best_lap_time": 8.1, "next_learning_rate": 1.5e-4}


def test_an_anneal_rollback_is_said_in_80_columns_and_on_the_dashboard() -> None:
    out = io.StringIO()
    progress = PlainProgress(out, StopConditions(max_minutes=None), heartbeat=60.0)
    data = DashboardData(title="t", stop=StopConditions(max_minutes=None))
    sink = LiveSink(data)
    for iteration in range(38, 42):
        summary = _summary(iteration)
        summary.learning_rate = 3e-4 if iteration <= 40 else 1.5e-4
        summary.extra = dict(ROLLBACK) if iteration == 40 else {"lr_factor": 1.0 if iteration < 40 else 0.5}
        progress.on_iteration(summary, [])
        sink.on_iteration(summary, [])
    lines = out.getvalue().splitlines()
    note = [line for line in lines if "iteration 40:" in line or line.startswith(" ")]
    assert len(note) == 2 and all(len(line) <= 80 for line in note), note
    assert note[0].endswith("iteration 40: 3 evaluations slower than 1.05x the best lap (8.10 s);")
    assert note[1].strip() == "back to the best checkpoint (iteration 28), learning rate 0.00015"
    assert sum("evaluations slower" in line for line in lines) == 1  # said for its iteration only
    console = Console(width=200, record=True)  # the panel's sentence on one line
    console.print(render(data))
    text = " ".join(console.export_text().split())
    assert "back to the best checkpoint (iteration 28), learning rate 0.00015" in text
    assert "Learning rate 0.00015" in text and "Back to the best 1 time (rate x0.5)" in text


def test_a_run_under_another_schedule_shows_no_rollbacks() -> None:
    data = DashboardData(title="t", stop=StopConditions(max_minutes=None))
    LiveSink(data).on_iteration(_summary(), [])
    text = " ".join(_text(render(data)).split())
    assert "Back to the best -" in text and "evaluations slower" not in text
