"""Training progress as plain lines, for when stdout is not a terminal (``drx train > log``, CI, make).

A first line names the device the job trains on; then one line per iteration, and a heartbeat
line whenever nothing was printed for :data:`HEARTBEAT_SECONDS` (a long update or a slow
episode), so a log never goes silent for minutes. The heartbeat runs in a background thread: torch
releases the GIL in its operations, so it prints during an update too.
"""

from __future__ import annotations

import threading
import time
from typing import TextIO

from drx.settings.stop import StopConditions
from drx.train.anneal import summary_rollback, wrap
from drx.train.health import collapse_warning
from drx.train.records import EpisodeRecord, IterationSummary, NullSink, describe_by_track

HEARTBEAT_SECONDS = 30.0  # [s] the longest a running job's log stays silent
STAMP = len("[0:00:00] ")  # the elapsed time in front of every line
COLUMNS = 80  # a note (an anneal rollback) wraps to these


def clock(seconds: float | None) -> str:
    """``h:mm:ss`` (``-`` for ``None``)."""
    if seconds is None:
        return "-"
    seconds = max(0, int(seconds))
    return f"{seconds // 3600}:{seconds % 3600 // 60:02d}:{seconds % 60:02d}"


def _num(value: float | None, spec: str) -> str:
    return "-" if value is None else f"{value:{spec}}"


class PlainProgress(NullSink):
    """A training sink that writes plain progress lines to a stream.

    :param stream: where the lines go (stdout, or stderr under ``--json``).
    :param stop: the job's stop conditions (for the time left).
    :param heartbeat: [s] the longest silence while the run goes on.
    :param stop_flag: a one-item list; a true first item asks the run to stop (Ctrl-C).
    :param model: the model's name (for the commands a collapse warning suggests).
    :param device: the device the job trains on, described (:func:`drx.train.device.describe_device`);
        written once, when the lines start.
    """

    def __init__(
        self,
        stream: TextIO,
        stop: StopConditions,
        heartbeat: float = HEARTBEAT_SECONDS,
        stop_flag: list[bool] | None = None,
        model: str | None = None,
        device: str | None = None,
    ) -> None:
        self.stream = stream
        self.model = model
        self.device = device
        self.evaluations: list[tuple[int, float | None]] = []
        self.warned = False
        self.stop = stop
        self.heartbeat = float(heartbeat)
        self.stop_flag = stop_flag if stop_flag is not None else [False]
        self.phase = "starting"
        self.iteration = 0
        self.episodes_in_iteration = 0
        self.steps = 0
        self._origin = time.monotonic()
        self._last_line = time.monotonic()
        self._lock = threading.Lock()
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._beat, name="drx-progress", daemon=True)

    # ----- lifecycle -------------------------------------------------------------------
    def start(self) -> None:
        """Say the device (when known), then start the heartbeat thread."""
        if self.device:
            self.line(f"training on {self.device}")
        self._thread.start()

    def close(self) -> None:
        """Stop the heartbeat thread."""
        self._done.set()
        if self._thread.is_alive():
            self._thread.join(timeout=5)

    def __enter__(self) -> PlainProgress:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ----- lines -------------------------------------------------------------------------
    def elapsed(self) -> float:
        """[s] wall time since the job started (as the trainer last reported it, running on)."""
        return time.monotonic() - self._origin

    def _left(self) -> str:
        if self.stop.max_minutes is None:
            return ""
        return f" / left {clock(max(0.0, self.stop.max_minutes * 60 - self.elapsed()))}"

    def line(self, text: str) -> None:
        """Write one line stamped with the elapsed time, and flush it."""
        with self._lock:
            self.stream.write(f"[{clock(self.elapsed())}] {text}\n")
            self.stream.flush()
            self._last_line = time.monotonic()

    def _beat(self) -> None:
        while not self._done.wait(min(1.0, self.heartbeat / 4)):
            if time.monotonic() - self._last_line >= self.heartbeat:
                stopping = " (stopping)" if self.stop_flag[0] else ""
                self.line(
                    f"iteration {self.iteration}: {self.phase}{stopping}, "
                    f"{self.episodes_in_iteration} episodes, {self.steps} steps so far{self._left()}"
                )

    # ----- sink ----------------------------------------------------------------------------
    def on_phase(self, phase: str, elapsed: float) -> None:
        """Remember the phase and re-anchor the clock on the trainer's elapsed time."""
        self.phase = phase
        self._origin = time.monotonic() - elapsed

    def on_step(self, steps: int) -> None:
        """Running step count."""
        self.steps = steps

    def on_episode(self, record: EpisodeRecord) -> None:
        """Count the iteration's episodes."""
        self.iteration = record.iteration
        self.episodes_in_iteration = record.episode + 1

    def on_iteration(self, summary: IterationSummary, episodes: list[EpisodeRecord]) -> None:
        """One line per iteration: steps, speed, reward, evaluation, time; then a note when the
        ``anneal`` schedule went back to the best checkpoint, and a collapse warning once."""
        self.steps = summary.steps
        cut = " (update cut at the limit)" if summary.extra.get("update_cut") else ""
        evaluation = (
            f"eval progress {_num(summary.eval_mean_progress, '.0f')}%, "
            f"{summary.eval_laps_complete}/{summary.eval_episodes} laps"
            if summary.eval_episodes
            else "not evaluated (limit reached or stopping)"
        )
        # a model training on several tracks: each track's reward / progress (kept apart, as its records)
        per_track = f" (per track: {describe_by_track(summary.by_track)})" if summary.by_track else ""
        self.line(
            f"iteration {summary.iteration} done: {summary.steps} steps, {summary.episodes} episodes, "
            f"{summary.steps_per_second:.0f} steps/s, reward {_num(summary.train_mean_reward, '.1f')}, "
            f"progress {_num(summary.train_mean_progress, '.0f')}%{per_track}, "
            f"{evaluation}{cut}{self._left()}"
        )
        rollback = summary_rollback(summary.iteration, summary.extra)
        if rollback:  # the anneal schedule went back to the best checkpoint (drx.train.anneal)
            self.line(f"\n{' ' * STAMP}".join(wrap(rollback, COLUMNS - STAMP)))
        self.iteration = summary.iteration + 1
        self.episodes_in_iteration = 0
        shown = summary.eval_mean_progress if summary.eval_episodes else None
        self.evaluations.append((summary.iteration, shown))
        warning = collapse_warning(self.evaluations, self.model)
        if warning and not self.warned:
            self.line(f"warning: {warning}")
        self.warned = warning is not None  # said once per collapse; again if it recovers and falls

    def stop_requested(self) -> bool:
        """Ctrl-C was pressed once."""
        return bool(self.stop_flag[0])
