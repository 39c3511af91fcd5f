"""Per-step bookkeeping: episode totals and DeepRacer's training trace CSV.

The trace has one row per step with the columns of DeepRacer's simulator trace
(``../shared/DEEPRACER.md`` section 6), one file per iteration,
``training-simtrace/<iteration>-iteration.csv``, as deepracer-for-cloud writes
it, so ``deepracer.logs.DeepRacerLog(model_folder=...).load_training_trace()``
reads a drx model folder as it is.
"""

from __future__ import annotations

import csv
import math
import time
from pathlib import Path
from typing import IO, Any

import numpy as np

from drx.sim.episode_status import EpisodeStatus
from drx.train.records import EpisodeRecord

TRACE_COLUMNS = (
    "episode",
    "steps",
    "X",
    "Y",
    "yaw",
    "steer",
    "throttle",
    "action",
    "reward",
    "done",
    "all_wheels_on_track",
    "progress",
    "closest_waypoint",
    "track_len",
    "tstamp",
    "episode_status",
    "pause_duration",
    "obstacle_crash_counter",
)
STEP_SECONDS = 1.0 / 15.0  # [s] DeepRacer's step: one camera frame at 15 frames/s
SIMTRACE_DIR = "training-simtrace"


def trace_row(
    episode: int,
    action: Any,
    reward: float,
    done: bool,
    info: dict[str, Any],
    tstamp: float,
    crashes: int,
    continuous: bool,
    scaled_action: tuple[float, float] | None = None,
    pause: float = 0.0,
) -> tuple[Any, ...]:
    """One step as a row of :data:`TRACE_COLUMNS` (training and evaluation traces alike).

    :param info: the env's step info (``params``, ``progress``, ``episode_status``).
    :param tstamp: [s] simulated time of the step.
    :param crashes: crashes in the episode so far, this step's included (``obstacle_crash_counter``).
    :param scaled_action: (steering deg, speed m/s) of a continuous action, for its ``action`` label.
    :param pause: [s] the penalty the car stands for on a ``pause`` row (``pause_duration``).
    """
    p = info.get("params", {})
    return (
        episode,
        int(p.get("steps", info.get("steps", 0))),
        f"{p.get('x', 0.0):.4f}",
        f"{p.get('y', 0.0):.4f}",
        f"{p.get('heading', 0.0):.4f}",
        f"{p.get('steering_angle', 0.0):.2f}",
        f"{p.get('speed', 0.0):.2f}",
        action_label(action, continuous, scaled_action),
        f"{reward:.4f}",
        done,
        bool(p.get("all_wheels_on_track", True)),
        f"{float(info.get('progress', p.get('progress', 0.0))):.4f}",
        closest_waypoint(p),
        f"{p.get('track_length', 0.0):.2f}",
        f"{tstamp:.3f}",
        info.get("episode_status", EpisodeStatus.IN_PROGRESS),
        round(pause, 3),
        crashes,
    )


def closest_waypoint(params: dict[str, Any]) -> int:
    """The nearer of the two ``closest_waypoints`` to the car (the trace's ``closest_waypoint``)."""
    prev_i, next_i = params.get("closest_waypoints", (0, 0))
    waypoints = params.get("waypoints")
    if not waypoints:
        return int(next_i)
    x, y = params.get("x", 0.0), params.get("y", 0.0)
    px, py = waypoints[prev_i]
    nx, ny = waypoints[next_i]
    return int(prev_i if math.hypot(px - x, py - y) <= math.hypot(nx - x, ny - y) else next_i)


def action_label(action: Any, continuous: bool, scaled: tuple[float, float] | None = None) -> str | int:
    """The trace's ``action``: the index, or ``[steer, speed]`` for a continuous car."""
    if not continuous:
        return int(np.asarray(action).reshape(-1)[0])
    if scaled is None:
        a = np.asarray(action, dtype=float).reshape(-1)
        scaled = (float(a[0]), float(a[1]))
    return f"[{scaled[0]:.4g}, {scaled[1]:.4g}]"


class EpisodeTracker:
    """Adds up one phase's steps into :class:`EpisodeRecord` s.

    :param phase: ``training`` or ``evaluation``.
    """

    def __init__(self, phase: str) -> None:
        self.phase = phase
        self._reset()

    def _reset(self) -> None:
        self.reward = 0.0
        self.steps = 0
        self.progress = 0.0  # the most reached so far [%] (DeepRacer's episode progress)
        self.start_fraction: float | None = None
        self.track: str | None = None
        self.started = time.monotonic()

    def step(self, reward: float, info: dict[str, Any]) -> None:
        """Count one step."""
        if self.steps == 0:
            self.start_fraction = float(
                info.get("start_fraction", info.get("params", {}).get("start_fraction", 0.0))
            )
            track = info.get("track")  # a model's training env names the route (drx.sim.schedule)
            self.track = None if track is None else str(track)
        self.reward += reward
        self.steps += 1
        progress = info.get("progress", info.get("params", {}).get("progress", 0.0))
        self.progress = max(self.progress, float(progress))

    def finish(
        self, info: dict[str, Any], iteration: int, episode: int, global_episode: int
    ) -> EpisodeRecord:
        """Close the episode on its last step's ``info``."""
        params = info.get("params", {})
        progress = max(self.progress, float(info.get("progress", params.get("progress", 0.0))))
        status = str(info.get("episode_status", EpisodeStatus.IN_PROGRESS))
        lap_time = info.get("lap_time")
        record = EpisodeRecord(
            iteration=iteration,
            episode=episode,
            global_episode=global_episode,
            phase=self.phase,
            reward=self.reward,
            progress=progress,
            steps=int(info.get("steps", self.steps)),
            status=status,
            lap_time=None if lap_time is None or status != EpisodeStatus.LAP_COMPLETE else float(lap_time),
            start_fraction=float(self.start_fraction or 0.0),
            wall_seconds=time.monotonic() - self.started,
            track=self.track,
        )
        self._reset()
        return record


class TraceWriter:
    """Writes the training trace, one CSV per iteration.

    Writing an iteration's file again (a resumed run repeating an iteration)
    replaces it, so a trace never holds a step twice.

    :param model_folder: the model's artifacts folder.
    :param continuous: whether the car's action space is continuous.
    """

    def __init__(self, model_folder: Path, continuous: bool) -> None:
        self.folder = Path(model_folder) / SIMTRACE_DIR
        self.folder.mkdir(parents=True, exist_ok=True)
        self.continuous = continuous
        self._file: IO[str] | None = None
        self._writer: Any = None
        self._episode: int | None = None  # the episode whose crashes ``_crashes`` counts
        self._crashes = 0

    def start_iteration(self, iteration: int) -> Path:
        """Open (and truncate) ``<iteration>-iteration.csv``."""
        self.close()
        path = self.folder / f"{iteration}-iteration.csv"
        self._file = path.open("w", newline="", buffering=1 << 16)
        self._writer = csv.writer(self._file)
        self._writer.writerow(TRACE_COLUMNS)
        return path

    def write(
        self,
        episode: int,
        action: Any,
        reward: float,
        done: bool,
        info: dict[str, Any],
        tstamp: float,
        scaled_action: tuple[float, float] | None = None,
    ) -> None:
        """Append one step's row."""
        if self._writer is None:
            return
        if episode != self._episode:
            self._episode, self._crashes = episode, 0
        # crashes in the episode so far, this one included
        if info.get("episode_status") == EpisodeStatus.CRASHED:
            self._crashes += 1
        self._writer.writerow(
            trace_row(
                episode, action, reward, done, info, tstamp,
                crashes=self._crashes, continuous=self.continuous, scaled_action=scaled_action,
            )
        )  # fmt: skip

    def flush(self) -> None:
        """Push buffered rows to the file."""
        if self._file is not None:
            self._file.flush()

    def close(self) -> None:
        """Close the current iteration's file."""
        if self._file is not None:
            self._file.close()
        self._file = None
        self._writer = None
