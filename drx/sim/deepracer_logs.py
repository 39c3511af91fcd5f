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
length (regression slope 0.01 on the console logs, -0.08 on simapp 5's, 1 if
the clock were the car's), and consecutive logged lengths are anti-correlated
(-0.52), as a noisy reading of a steady clock makes them.
:attr:`LoggedEpisode.step_times` therefore gives every sane step the
episode's mean length; :func:`step_length_jitter` measures the car's own
step-to-step variation from the distances instead.
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

TRACE_PREFIX = "SIM_TRACE_LOG:"
MIN_DT, MAX_DT = 0.02, 0.2  # [s] logged step lengths outside this are gaps in the log, not steps
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
    def sane_steps(self) -> np.ndarray:
        """``(len - 1,)`` bool: the logged step from each row to the next lasts ``MIN_DT``-``MAX_DT`` (a
        longer one is a pause or reset, a shorter one a glitch)."""
        dt = np.diff(self.tstamp)
        return (dt >= MIN_DT) & (dt <= MAX_DT)

    @functools.cached_property
    def step_time(self) -> float:
        """The episode's mean step length [s] over its sane steps (1/15 s when it has none)."""
        dt = np.diff(self.tstamp)[self.sane_steps]
        return float(dt.mean()) if dt.size else 1.0 / 15.0

    @functools.cached_property
    def step_times(self) -> np.ndarray:
        """``(len - 1,)`` [s]: how long the car drove between each row and the next: :attr:`step_time`
        for a sane step (the logged clock jitters independently of the car, see the module docstring),
        the logged gap otherwise."""
        return np.where(self.sane_steps, self.step_time, np.diff(self.tstamp))


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


# The shared calibration logs (``../shared/deepracer-logs/README.md``): name -> glob under that folder.
# The DeepRacer simulator version (deepracer-simapp) that recorded each set: the README's table, and
# ``environment.simulation_version`` in the deepracer-for-cloud logs' ``*.meta.json``.
SIMULATOR_OF_SET = {"console-reinvent_base": "4", "drfc-4workers": "5"}
SHARED_LOG_SETS = {
    "console-reinvent_base": "console-reinvent_base-2022-06/logs/sample-console-logs/sim-trace/training/"
    "training-simtrace/*-iteration.csv",
    "drfc-4workers": "drfc-2023-02-4workers/*_robomaker.*.log",
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


@dataclass(frozen=True)
class StepLengthJitter:
    """How much the car's steps vary in length, from how far it moved (:func:`step_length_jitter`).

    :param relative_sd: standard deviation of a step's length over the mean [-].
    :param lag1: correlation of consecutive steps' deviations [-] (-0.5: the moments the agent reads
        the car jitter around a steady beat; 0: steps of independent lengths).
    :param clock_slope: regression slope of a step's relative distance on its relative logged length
        [-] (1 if the logged clock were the car's, 0 if it says nothing of it).
    :param steps: steps measured.
    """

    relative_sd: float
    lag1: float
    clock_slope: float
    steps: int


def step_length_jitter(
    episodes: list[LoggedEpisode], run: int = 8, max_steering: float = 30.0
) -> StepLengthJitter:
    """The variation of the car's step lengths, read from the distances it covers.

    In runs of ``run`` steps where the speed command is held and ``|steering| <= max_steering`` deg (the
    car moving at least 5 cm a step), each step's distance is divided by a quadratic fitted through the
    run (the car's smooth speed); what is left is the step's relative length, plus the pose's own
    noise. Its standard deviation (corrected for the three fitted terms) is ``relative_sd``.
    """
    devs: list[np.ndarray] = []
    clock: list[tuple[float, float]] = []
    t = np.arange(run)
    for ep in episodes:
        origin_x = ep.x - 0.14 * np.cos(ep.yaw)  # the origin, 0.14 m behind the reference point
        origin_y = ep.y - 0.14 * np.sin(ep.yaw)
        dist = np.hypot(np.diff(origin_x), np.diff(origin_y))
        driving = np.array([s == "in_progress" for s in ep.status]) & np.append(ep.sane_steps, False)
        logged = np.diff(ep.tstamp)
        j = 0
        while j + run < len(ep):
            span = slice(j, j + run)
            held = np.ptp(ep.throttle[span]) == 0.0 and np.abs(ep.steer[span]).max() <= max_steering
            if held and driving[span].all() and dist[span].min() >= 0.05:
                d = dist[span]
                rel = d / np.polyval(np.polyfit(t, d, 2), t)
                devs.append(rel - 1.0)
                clock.extend(zip(logged[span] / ep.step_time, rel, strict=True))
                j += run
            else:
                j += 1
    if not devs:
        return StepLengthJitter(0.0, 0.0, 0.0, 0)
    r = np.array(devs)
    a = np.array(clock)
    return StepLengthJitter(
        relative_sd=float(r.std() * math.sqrt(run / (run - 3))),
        lag1=float(np.corrcoef(r[:, :-1].ravel(), r[:, 1:].ravel())[0, 1]),
        clock_slope=float(np.polyfit(a[:, 0], a[:, 1], 1)[0]),
        steps=r.size,
    )
