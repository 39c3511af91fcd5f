"""The evaluation trace, as deepracer-for-cloud writes it, for ``deepracer-utils`` and ``drx analyze``.

An evaluation's steps go to
``<model folder>/evaluation-<YYYYMMDDhhmmss>/evaluation-simtrace/0-iteration.csv`` with the
training trace's columns (:data:`drx.train.trace.TRACE_COLUMNS`). Each lap is one episode
(``episode`` = lap - 1); after an off-track or a crash the car is put back and the lap, its
episode and its step count go on, as in DeepRacer's evaluations: a penalty shows as one row with
``episode_status`` ``pause`` at the reset pose whose ``pause_duration`` is the penalty [s], and the
``tstamp`` clock moves on by it. ``obstacle_crash_counter``
counts the crashes into boxes and bots in the episode so far (this step's included).

:class:`EvaluationTraceWriter` is a Gymnasium wrapper, so any evaluation loop (such as
:func:`drx.evaluate.time_trial.run_time_trial`) writes the trace by driving the wrapped env::

    with EvaluationTraceWriter(env, model_folder(name), vehicle.continuous) as traced:
        result = run_time_trial(traced, policy, rules)
"""

from __future__ import annotations

import csv
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import IO, Any, Literal

import gymnasium as gym

from drx.sim.episode_status import EpisodeStatus
from drx.train.trace import STEP_SECONDS, TRACE_COLUMNS, trace_row

EVALUATION_SIMTRACE = "evaluation-simtrace"


def new_evaluation_dir(model_folder: Path, when: datetime | None = None) -> Path:
    """A fresh ``evaluation-<YYYYMMDDhhmmss>`` folder (UTC; one second later while the name is taken)."""
    when = (when or datetime.now(UTC)).astimezone(UTC)
    while True:
        folder = Path(model_folder) / f"evaluation-{when:%Y%m%d%H%M%S}"
        try:
            (folder / EVALUATION_SIMTRACE).mkdir(parents=True, exist_ok=False)
            return folder
        except FileExistsError:
            when += timedelta(seconds=1)


class EvaluationTraceWriter(gym.Wrapper):
    """Writes every step of the wrapped env to a new evaluation trace.

    A ``reset`` with ``options={"resume": True}`` (back on the track after an off-track)
    continues the lap's episode; any other reset after the first starts the next episode.

    :param env: a ``drx/DeepRacer-v0`` env in evaluation mode (or a wrapper of one).
    :param model_folder: the model's folder; the trace goes to a new ``evaluation-<time>`` folder in it.
    :param continuous: whether the car's action space is continuous (the ``action`` column's form).
    :param when: the evaluation's start time (names the folder); default now.
    """

    def __init__(
        self, env: gym.Env, model_folder: Path, continuous: bool, when: datetime | None = None
    ) -> None:
        super().__init__(env)
        self.folder = new_evaluation_dir(model_folder, when)
        self.path = self.folder / EVALUATION_SIMTRACE / "0-iteration.csv"
        self.continuous = continuous
        self._file: IO[str] | None = self.path.open("w", newline="")
        self._writer = csv.writer(self._file)
        self._writer.writerow(TRACE_COLUMNS)
        self._episode = -1
        self._crashes = 0  # in the current episode
        self._clock = 0.0  # [s] simulated time since the evaluation started

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[Any, dict]:
        """Reset the env; a new episode unless the car is only put back on the track."""
        obs, info = self.env.reset(seed=seed, options=options)
        if self._episode < 0 or not (options or {}).get("resume"):
            self._episode += 1
            self._crashes = 0
        elif info.get("episode_status") == EpisodeStatus.PAUSE:  # DeepRacer logs the penalty as a paused row
            pause = float(info.get("pause_duration", 0.0))
            self._clock += pause
            self._write(0, 0.0, False, info, pause)
        return obs, info

    def step(self, action: Any) -> tuple[Any, Any, bool, bool, dict]:
        """Step the env and append the step's row."""
        obs, reward, terminated, truncated, info = self.env.step(action)
        self._clock += float(info.get("step_time", STEP_SECONDS))
        self._write(action, float(reward), bool(terminated or truncated), info)
        return obs, reward, terminated, truncated, info

    def _write(
        self, action: Any, reward: float, done: bool, info: dict[str, Any], pause: float = 0.0
    ) -> None:
        if self._file is None:
            return
        p = info.get("params", {})
        if info.get("episode_status") == EpisodeStatus.CRASHED:
            self._crashes += 1
        scaled = None
        if self.continuous:
            scaled = (float(p.get("steering_angle", 0.0)), float(p.get("speed", 0.0)))
        self._writer.writerow(
            trace_row(
                max(self._episode, 0), action, reward, done, info, self._clock,
                crashes=self._crashes, continuous=self.continuous, scaled_action=scaled, pause=pause,
            )
        )  # fmt: skip

    def close(self) -> None:
        """Close the trace file (and the env)."""
        if self._file is not None:
            self._file.close()
            self._file = None
        super().close()

    def __enter__(self) -> EvaluationTraceWriter:
        return self

    def __exit__(self, *exc: object) -> Literal[False]:
        if self._file is not None:
            self._file.close()
            self._file = None
        return False  # exceptions propagate
