"""Read the DeepRacer simulator's step traces: sim-trace CSVs and robomaker logs.

Two layouts carry the same columns (``../shared/deepracer-logs/README.md``,
DEEPRACER.md section 6):

* the console's per-iteration CSV (``training-simtrace/N-iteration.csv``), with
  a header row: ``episode,steps,X,Y,yaw,steer,throttle,action,reward,done,
  all_wheels_on_track,progress,closest_waypoint,track_len,tstamp,episode_status
  [,pause_duration]``;
* a robomaker log, whose step lines start with ``SIM_TRACE_LOG:`` followed by
  the same fields, comma-separated (deepracer-simapp
  ``markov/metrics/iteration_data.py`` / ``utils.py`` ``log_sim_trace``).

Only what replaying and fitting need is kept: per episode, arrays of the
reference point, heading, commanded steering and speed, progress, sim time and
status. A continuous action's ``action`` field (``[steer speed]``) may contain
spaces but no comma, so the fields are split on commas from both ends.

**The logged clock is not the car's.** ``tstamp`` is the simulation time the
agent last heard on ``/clock`` (deepracer-simapp
``bundle/markov/agent_ctrl/rollout_agent_ctrl.py``: ``update_tracker`` stores
it, the step's metrics log it), not the moment the pose was read, so its
steps jitter (10 ms sd on simapp 5's logs) independently of how far the car
moved: at a held command the distance of a step does not grow with its logged
length (regression slope 0.01 on the console logs, -0.04 on simapp 5's, 1 if
the clock were the car's), consecutive logged lengths are anti-correlated
(-0.52), as a noisy reading of a steady clock makes them, and the distance
driven over 8 steps follows the step count more closely than the logged time
(:func:`drx.sim.step_jitter.step_length_jitter`: the logged time leaves 1.7-2.1
times the residual). :attr:`LoggedEpisode.step_times` therefore gives every sane
step the episode's mean length; :mod:`drx.sim.step_jitter` measures the car's
own step-to-step variation from the distances instead.
"""

from __future__ import annotations

import csv
import functools
import io
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from drx.errors import DrxError
from drx.sim.episode_status import EpisodeStatus

TRACE_PREFIX = "SIM_TRACE_LOG:"
MIN_DT, MAX_DT = 0.02, 0.2  # [s] logged step lengths outside this are gaps in the log, not steps
NOMINAL_STEP = 1.0 / 15.0  # [s] DeepRacer's step at 15 Hz
# Positions of the fields we read, counted from the left of a trace row.
_EPISODE, _STEPS, _X, _Y, _YAW, _STEER, _THROTTLE = range(7)
# ... and from the right: progress, closest_waypoint, track_len, tstamp, episode_status (pause_duration)
_RIGHT_FIELDS = 5


@dataclass(frozen=True)
class LoggedEpisode:
    """One episode of a DeepRacer trace, as arrays with one entry per logged step.

    :param episode: the episode number in the log.
    :param x: reference-point x [m] (the reward ``params`` x, 0.14 m ahead of the car's origin).
    :param y: reference-point y [m].
    :param yaw: heading [rad].
    :param steer: commanded steering of the action taken at this step [deg], + = left.
    :param throttle: commanded speed of the action taken at this step [m/s].
    :param progress: [%] of the lap from the episode's start.
    :param tstamp: simulation time [s].
    :param status: ``episode_status`` per step (``prepare``, ``in_progress``, ``off_track``, ...).
    :param source: the file it came from.
    """

    episode: int
    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    steer: np.ndarray
    throttle: np.ndarray
    progress: np.ndarray
    tstamp: np.ndarray
    status: tuple[str, ...]
    source: str

    def __len__(self) -> int:
        return len(self.x)

    @functools.cached_property
    def driving(self) -> np.ndarray:
        """``(len,)`` bool: the row is ``in_progress`` (not a start, reset, pause or ending)."""
        return np.array([s == EpisodeStatus.IN_PROGRESS for s in self.status], dtype=bool)

    @functools.cached_property
    def sane_steps(self) -> np.ndarray:
        """``(len - 1,)`` bool: the logged step from each row to the next lasts ``MIN_DT``-``MAX_DT`` (a
        longer one is a pause or reset, a shorter one a glitch)."""
        dt = np.diff(self.tstamp)
        return (dt >= MIN_DT) & (dt <= MAX_DT)

    @functools.cached_property
    def step_time(self) -> float:
        """The episode's mean step length [s] over its sane steps (1/15 s when it has none)."""
        dt = np.diff(self.tstamp)[self.sane_steps]
        return float(dt.mean()) if dt.size else NOMINAL_STEP

    @functools.cached_property
    def step_times(self) -> np.ndarray:
        """``(len - 1,)`` [s]: how long a replay drives between each row and the next: :attr:`step_time`
        for a sane step (the logged clock jitters independently of the car, see the module docstring),
        one nominal step (:data:`NOMINAL_STEP`) across a gap, whose driving the log does not show."""
        return np.where(self.sane_steps, self.step_time, NOMINAL_STEP)


def read_trace(path: str | Path) -> list[LoggedEpisode]:
    """The episodes of one sim-trace CSV or robomaker log, in file order.

    :raises DrxError: when the file is missing or holds no trace rows.
    """
    p = Path(path)
    if not p.is_file():
        raise DrxError(f"DeepRacer log {str(p)!r} does not exist or is not a file; give a sim-trace CSV "
                       "or a robomaker log.")
    text = p.read_text(encoding="utf-8", errors="replace")
    rows = _trace_rows(text)
    if not rows:
        raise DrxError(f"{str(p)!r} holds no DeepRacer trace rows; give a sim-trace CSV (with its header) "
                       f"or a robomaker log with {TRACE_PREFIX} lines.")
    return _episodes(rows, str(p))


def read_traces(paths: list[str | Path]) -> list[LoggedEpisode]:
    """The episodes of several files (see :func:`read_trace`), one list."""
    out: list[LoggedEpisode] = []
    for path in paths:
        out.extend(read_trace(path))
    return out


def _trace_rows(text: str) -> list[list[str]]:
    if TRACE_PREFIX in text:
        lines = [ln.split(TRACE_PREFIX, 1)[1] for ln in text.splitlines() if TRACE_PREFIX in ln]
    else:
        lines = text.splitlines()
        if not lines or not lines[0].lower().startswith("episode,"):
            return []
        lines = lines[1:]
    rows = []
    for fields in csv.reader(io.StringIO("\n".join(lines))):
        if len(fields) < 7 + _RIGHT_FIELDS:
            continue
        rows.append(fields)
    return rows


def _right(fields: list[str]) -> list[str]:
    """progress, closest_waypoint, track_len, tstamp, episode_status — whether or not
    ``pause_duration`` follows."""
    tail = fields[-6:] if _is_number(fields[-1]) and not _is_number(fields[-2]) else fields[-5:] + [""]
    return tail[:5]


def _is_number(s: str) -> bool:
    try:
        float(s)
    except ValueError:
        return False
    return True


def _episodes(rows: list[list[str]], source: str) -> list[LoggedEpisode]:
    by_episode: dict[int, list[tuple[float, ...]]] = {}
    statuses: dict[int, list[str]] = {}
    for fields in rows:
        try:
            progress, _wp, _len, tstamp, status = _right(fields)
            values = (
                float(fields[_X]), float(fields[_Y]), float(fields[_YAW]), float(fields[_STEER]),
                float(fields[_THROTTLE]), float(progress), float(tstamp),
            )  # fmt: skip
            episode = int(float(fields[_EPISODE]))
        except ValueError:
            continue
        if not all(math.isfinite(v) for v in values):
            continue
        by_episode.setdefault(episode, []).append(values)
        statuses.setdefault(episode, []).append(status.strip())
    out = []
    for episode, samples in by_episode.items():
        a = np.asarray(samples, dtype=np.float64)
        out.append(
            LoggedEpisode(
                episode=episode, x=a[:, 0], y=a[:, 1], yaw=np.radians(a[:, 2]), steer=a[:, 3],
                throttle=a[:, 4], progress=a[:, 5], tstamp=a[:, 6], status=tuple(statuses[episode]),
                source=source,
            )
        )  # fmt: skip
    return out


# The shared calibration logs (``../shared/deepracer-logs/README.md``), one entry per recording (a
# training run): name -> glob under that folder. ``console-continuous-2021`` holds two runs on two tracks
# with two action spaces, so it is two logs here.
SHARED_LOG_SETS = {
    "console-reinvent_base": "console-reinvent_base-2022-06/logs/sample-console-logs/sim-trace/training/"
    "training-simtrace/*-iteration.csv",
    "drfc-4workers": "drfc-2023-02-4workers/*_robomaker.*.log",
    "drfc-june-pro": "drfc-2022-june-pro/*_robomaker.*.log",
    "console-continuous-reInvent2019": "console-continuous-2021/reInvent2019_track-1.5-3/*-iteration.csv",
    "console-continuous-reinvent_base": "console-continuous-2021/reinvent_base-0.5-4/*-iteration.csv",
}
# The DeepRacer simulator version (deepracer-simapp) that recorded each log, as its metadata says: the
# console log's ``model/model_metadata.json`` (``"version": "4.0"``), the deepracer-for-cloud logs'
# ``*.meta.json`` (``environment.simulation_version`` 5.0) and their robomaker lines (``simapp_version
# 5.0``). The 2021 console traces record none: they are the console's, before simapp 5 (2022-07 in
# deepracer-for-cloud), and version 4's car replays them closer than version 5's (21.6 against 28.5 cm
# median after 15 steps on the reInvent2019 run, 22.7 against 36.8 cm on the reinvent_base run, with
# the cars of 2026-11-23 that had not seen them), so they count as version 4's.
SIMULATOR_OF_SET = {
    "console-reinvent_base": "4",
    "drfc-4workers": "5",
    "drfc-june-pro": "5",
    "console-continuous-reInvent2019": "4",
    "console-continuous-reinvent_base": "4",
}


def shared_log_sets(root: str | Path) -> dict[str, list[LoggedEpisode]]:
    """The episodes of each shared calibration log set under ``root`` (``shared/deepracer-logs``).

    :raises DrxError: when ``root`` holds none of them.
    """
    base = Path(root)
    out = {}
    for name, pattern in SHARED_LOG_SETS.items():
        files = sorted(base.glob(pattern), key=_natural)
        if files:
            out[name] = read_traces(list(files))
    if not out:
        raise DrxError(f"no DeepRacer logs under {str(base)!r}; point it at shared/deepracer-logs.")
    return out


def _natural(path: Path) -> tuple[int, str]:
    """``2-iteration.csv`` before ``10-iteration.csv``."""
    head = path.name.split("-", 1)[0]
    return (int(head) if head.isdigit() else -1, path.name)
