"""The live training dashboard (Rich), for ``drx train`` and ``drx jobs logs -f``.

It shows what the DeepRacer console's training page shows: where the run is
(iteration, episodes, steps, speed, time used and left against the stop
conditions), how it is doing (average reward and progress in training and
evaluation, best lap, the policy's losses and entropy), the machine's load,
and a chart of reward and progress per iteration that grows as iterations end.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from typing import Any

from rich.console import Group, RenderableType
from rich.panel import Panel
from rich.table import Table
from rich.text import Text

from drx.settings.stop import StopConditions
from drx.train.anneal import latest_rollback
from drx.train.health import collapse_warning
from drx.train.records import CheckpointRecord, EpisodeRecord, IterationSummary, NullSink, describe_by_track

BLOCKS = " ▁▂▃▄▅▆▇█"


@dataclass
class DashboardData:
    """Everything the dashboard draws; filled by :class:`LiveSink` or from the registry."""

    title: str
    stop: StopConditions
    status: str = "starting"
    iterations: list[IterationSummary] = field(default_factory=list)
    steps: int = 0
    episodes: int = 0
    iteration: int = 0
    iteration_episodes: int = 0
    episodes_per_iteration: int = 0
    elapsed: float = 0.0
    steps_per_second: float | None = None
    best_lap: float | None = None
    best_progress: float | None = None
    cpu_percent: float | None = None
    memory_mb: float | None = None
    note: str = ""
    finished: bool = False  # the run is over: nothing is left of the time budget to show
    phase: str = ""  # what the run is doing now ("sampling episodes", "updating the policy: epoch 3/10"...)
    clock_origin: float | None = None  # time.monotonic() at the job's start; the clock then runs live
    model: str | None = None  # the model's name, for the commands a collapse warning suggests
    device: str | None = None  # where the job trains: "cpu", "cuda:0 (NVIDIA A10G)" (drx.train.device)
    car: str | None = None  # whose car it trains on: "DeepRacer simulator 6 (...)" (drx.settings.car)

    def elapsed_now(self) -> float:
        """[s] wall time since the job started: live while it runs, frozen once it has finished."""
        if self.clock_origin is None or self.finished:
            return self.elapsed
        return max(0.0, time.monotonic() - self.clock_origin)


# ----- machine load ---------------------------------------------------------------
class ProcessLoad:
    """CPU (% of one core) and resident memory of a process: psutil when installed, else /proc."""

    def __init__(self, pid: int | None = None) -> None:
        self.pid = pid or os.getpid()
        self._last: tuple[float, float] | None = None
        try:
            import psutil

            self._proc: Any = psutil.Process(self.pid)
            self._proc.cpu_percent(None)
        except Exception:  # psutil missing, or the process is gone
            self._proc = None

    def sample(self) -> tuple[float | None, float | None]:
        """(cpu %, memory MB) since the previous sample."""
        if self._proc is not None:
            try:
                return float(self._proc.cpu_percent(None)), self._proc.memory_info().rss / 2**20
            except Exception:
                return None, None
        return self._proc_cpu(), self._proc_mem()

    def _proc_cpu(self) -> float | None:
        try:
            with open(f"/proc/{self.pid}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
            ticks = (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
        except (OSError, ValueError, IndexError):
            return None
        now = time.monotonic()
        last, self._last = self._last, (now, ticks)
        if last is None or now <= last[0]:
            return None
        return 100.0 * (ticks - last[1]) / (now - last[0])

    def _proc_mem(self) -> float | None:
        try:
            with open(f"/proc/{self.pid}/status") as f:
                for line in f:
                    if line.startswith("VmRSS:"):
                        return int(line.split()[1]) / 1024
        except (OSError, ValueError):
            return None
        return None


# ----- drawing --------------------------------------------------------------------
def _fmt_time(seconds: float | None) -> str:
    if seconds is None:
        return "-"
    seconds = max(0, int(seconds))
    return f"{seconds // 3600}:{seconds % 3600 // 60:02d}:{seconds % 60:02d}"


def _num(value: float | None, spec: str = ".2f", unit: str = "") -> str:
    return "-" if value is None else f"{value:{spec}}{unit}"


def chart_rows(values: list[float | None], width: int = 60, height: int = 5) -> list[str]:
    """A bar chart of ``values`` (one column per value, the latest ``width``) in block characters."""
    vals = [v for v in values[-width:]]
    finite = [v for v in vals if v is not None]
    if not finite:
        return [""] * height
    lo, hi = min(0.0, min(finite)), max(finite)
    span = (hi - lo) or 1.0
    levels = [None if v is None else (v - lo) / span * height * 8 for v in vals]
    rows = []
    for row in range(height - 1, -1, -1):
        line = []
        for level in levels:
            if level is None:
                line.append(" ")
                continue
            fill = level - row * 8
            line.append(BLOCKS[8] if fill >= 8 else BLOCKS[max(0, int(fill))] if fill > 0 else " ")
        rows.append("".join(line))
    return rows


def _chart(title: str, values: list[float | None], style: str, unit: str = "") -> RenderableType:
    finite = [v for v in values if v is not None]
    top = f"{max(finite):.1f}{unit}" if finite else "-"
    text = Text()
    text.append(
        f"{title}  (max {top}, last {_num(finite[-1] if finite else None, '.1f', unit)})\n", style="bold"
    )
    for line in chart_rows(values):
        text.append(line + "\n", style=style)
    return text


def render(data: DashboardData) -> RenderableType:
    """The dashboard for ``data``."""
    stop = data.stop
    elapsed = data.elapsed_now()
    remaining = None if stop.max_minutes is None or data.finished else stop.max_minutes * 60 - elapsed
    limits = []
    if stop.max_minutes is not None:
        limits.append(f"{stop.max_minutes:g} min")
    if stop.max_steps is not None:
        limits.append(f"{stop.max_steps} steps")
    if stop.max_episodes is not None:
        limits.append(f"{stop.max_episodes} episodes")
    if stop.target_iterations is not None:
        limits.append(f"{stop.target_iterations} full-lap evaluations in a row")
    last = data.iterations[-1] if data.iterations else None
    grid = Table.grid(padding=(0, 2))
    for _ in range(4):
        grid.add_column()
    per_it = f"/{data.episodes_per_iteration}" if data.episodes_per_iteration else ""
    rows = [
        (
            "Iteration",
            f"{data.iteration} ({data.iteration_episodes}{per_it} episodes)",
            "Status",
            f"{data.status}: {data.phase}" if data.phase and not data.finished else data.status,
        ),
        ("Episodes", str(data.episodes), "Steps", str(data.steps)),
        (
            "Steps/s (iteration / now)",
            f"{_num(last.steps_per_second if last else None, '.0f')} / {_num(data.steps_per_second, '.0f')}",
            "Elapsed / left",
            f"{_fmt_time(elapsed)} / {_fmt_time(remaining)}",
        ),
        (
            "Reward (train / eval)",
            f"{_num(last.train_mean_reward if last else None, '.1f')} / "
            f"{_num(last.eval_mean_reward if last else None, '.1f')}",
            "Progress (train / eval)",
            f"{_num(last.train_mean_progress if last else None, '.0f', '%')} / "
            f"{_num(last.eval_mean_progress if last else None, '.0f', '%')}",
        ),
        (
            "Best lap",
            _num(data.best_lap, ".2f", " s"),
            "Best eval progress",
            _num(data.best_progress, ".0f", "%"),
        ),
        (
            "Policy / value loss",
            f"{_num(last.policy_loss if last else None, '.4f')} / "
            f"{_num(last.value_loss if last else None, '.4f')}",
            "Entropy / KL",
            f"{_num(last.entropy if last else None, '.3f')} / {_num(last.kl if last else None, '.4f')}",
        ),
        (
            "Learning rate",
            _num(last.learning_rate if last else None, ".3g"),
            "Back to the best",
            _rollbacks(data.iterations),
        ),
        (
            "CPU / memory",
            f"{_num(data.cpu_percent, '.0f', '%')} / {_num(data.memory_mb, '.0f', ' MB')}",
            "Stops at",
            ", ".join(limits) or "never",
        ),
    ]
    for a, b, c, d in rows:
        grid.add_row(Text(a, style="dim"), b, Text(c, style="dim"), d)
    # on a line of its own: a GPU's name is longer than the grid's columns
    device = Text("Device: ", style="dim").append(data.device, style="default") if data.device else None
    car = Text("Car: ", style="dim").append(data.car, style="default") if data.car else None
    tracks = next((s.by_track for s in reversed(data.iterations) if s.by_track), None)
    if tracks:  # a model training on several tracks: each track's figures apart
        per_track = Text("Per track (train reward / progress): ", style="dim")
        per_track.append(describe_by_track(tracks), style="default")
    reward = _chart(
        "Reward per iteration (training)", [s.train_mean_reward for s in data.iterations], "green"
    )
    progress = _chart(
        "Progress per iteration (evaluation)", [s.eval_mean_progress for s in data.iterations], "cyan", "%"
    )
    parts: list[RenderableType] = [grid, *([device] if device else []), *([car] if car else [])]
    parts += [per_track] if tracks else []
    parts += [Text(""), reward, progress]
    rollback = latest_rollback([(s.iteration, s.extra) for s in data.iterations])
    if rollback:  # the anneal schedule went back to the best checkpoint (drx.train.anneal)
        parts.append(Text(rollback, style="yellow"))
    warning = collapse_warning([(s.iteration, s.eval_mean_progress) for s in data.iterations], data.model)
    if warning:
        parts.append(Text(f"warning: {warning}", style="bold red"))
    if data.note:
        parts.append(Text(data.note, style="yellow"))
    return Panel(Group(*parts), title=data.title, border_style="blue")


def _rollbacks(iterations: list[IterationSummary]) -> str:
    """How many times the ``anneal`` schedule went back to the best checkpoint, and the factor on
    the learning rate (``-`` for a run under another schedule)."""
    factors = [s.extra["lr_factor"] for s in iterations if "lr_factor" in s.extra]
    if not factors:
        return "-"
    times = sum("rollback_to" in s.extra for s in iterations)
    return f"{times} time{'s' if times != 1 else ''} (rate x{factors[-1]:g})"


# ----- live sink for the foreground ------------------------------------------------
class LiveSink(NullSink):
    """Feeds :class:`DashboardData` from the trainer in this process.

    :param data: the data the dashboard draws (the caller's Live reads it).
    :param stop_flag: a one-item list; a true first item asks the run to stop (Ctrl-C).
    """

    def __init__(self, data: DashboardData, stop_flag: list[bool] | None = None) -> None:
        self.data = data
        self.stop_flag = stop_flag if stop_flag is not None else [False]
        self.load = ProcessLoad()
        self._window: list[tuple[float, int]] = []

    def _tick(self, steps: int) -> None:
        now = time.monotonic()
        self._window.append((now, steps))
        self._window = [(t, s) for t, s in self._window if now - t <= 10.0]
        t0, s0 = self._window[0]
        if now - t0 > 0.5:
            self.data.steps_per_second = (steps - s0) / (now - t0)
        self.data.steps = steps
        self.data.cpu_percent, self.data.memory_mb = self.load.sample()

    def on_phase(self, phase: str, elapsed: float) -> None:
        """The run entered a phase; ``elapsed`` [s] since the job started sets the live clock."""
        self.data.phase = phase
        self.data.clock_origin = time.monotonic() - elapsed
        self.data.elapsed = elapsed
        self.data.cpu_percent, self.data.memory_mb = self.load.sample()

    def on_step(self, steps: int) -> None:
        """Running totals."""
        self.data.status = "stopping" if self.stop_flag[0] else "training"
        self._tick(steps)

    def on_episode(self, record: EpisodeRecord) -> None:
        """An episode ended."""
        self.data.episodes = record.global_episode + 1
        self.data.iteration = record.iteration
        self.data.iteration_episodes = record.episode + 1

    def on_iteration(self, summary: IterationSummary, episodes: list[EpisodeRecord]) -> None:
        """An iteration ended."""
        self.data.iterations.append(summary)
        if summary.eval_best_lap_time is not None:
            self.data.best_lap = min(self.data.best_lap or 1e9, summary.eval_best_lap_time)
        if summary.eval_mean_progress is not None:
            self.data.best_progress = max(self.data.best_progress or 0.0, summary.eval_mean_progress)
        self.data.status = "training"

    def on_checkpoint(self, record: CheckpointRecord) -> None:
        """Nothing to show beyond the iteration."""

    def stop_requested(self) -> bool:
        """Ctrl-C was pressed once."""
        return bool(self.stop_flag[0])
