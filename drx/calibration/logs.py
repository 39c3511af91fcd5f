"""Read the DeepRacer simulator's step traces, every layout it has written: sim-trace CSVs and robomaker logs.

DeepRacer's simulator (aws-deepracer-community/deepracer-simapp) writes one row per step to two places,
the same columns in the same order (``StepMetrics`` in ``bundle/markov/metrics/constants.py``):

* the sim-trace CSV (``training-simtrace/N-iteration.csv``): a header row naming the columns, then the
  rows, values joined by commas and nothing quoted (``write_simtrace_to_local_file`` in
  ``bundle/markov/metrics/s3_metrics.py``);
* the robomaker log: each step a line ``SIM_TRACE_LOG:`` and the values, comma-separated, no header
  (``sim_trace_log`` in the same file, a ``%``-format of the same ordered dict).

The columns grew over the versions (deepracer-simapp, the commits that changed ``sim_trace_log``'s
format and ``StepMetrics``):

====== ================================================================= =================================
fields columns                                                           written since
====== ================================================================= =================================
16     episode, steps, X, Y, yaw, steer, throttle, action, reward, done, 2020-03 (90644125, the first
       all_wheels_on_track, progress, closest_waypoint, track_len,       extract; ``action`` an index)
       tstamp, episode_status
17     the 16 and pause_duration                                         2021-02 (74d7062e; simapp 4 and 5)
18     the 17 and obstacle_crash_counter                                 2024-10 (e699ac31; the console
                                                                         in 2025)
19     the 18 and wall_clock                                             2026-02 (76989e9e)
====== ================================================================= =================================

``action`` is the action's index for a discrete action space and a bracketed pair for a continuous one,
as Python printed it: ``[-30.0, 2.41]`` (the list itself, before 2023-07) or ``[-20.0 3.62]``
(``"[{} {}]".format(...)`` in ``set_reward_and_metrics``, ``bundle/markov/agent_ctrl/utils.py``, since
2411cbcf, 2023-07). Neither is quoted, so a plain CSV split cuts the first one in two. The reader
therefore takes a bracketed ``[...]`` as one field first (a regex), then names the fields:

* a CSV with a header by the header, column by column, in whatever order (deepracer-utils' renames
  ``x``, ``y``, ``steering_angle``, ``speed`` read too); every row must have the header's count of fields;
* a ``SIM_TRACE_LOG`` line (or a CSV without a header) by its count of fields, 16 to 19 as in the table:
  the first 16 are the same in every version.

Rows of every status are kept, with it (``prepare``, ``pause``, ``off_track``, ``lap_complete``, ...;
a replay drives only the ``in_progress`` stretches, :mod:`drx.sim.episode_status`). A row that does
not read (a count of fields no layout has, a number that is not one, no status word) is *malformed*:
:func:`read_trace_file` counts it and says where (:class:`TraceFile`), nothing is dropped silently.
Reading is a compiled regex per line and a float per field read: 21,700 steps in about 0.1 s.

Only what replaying and fitting need is kept: per episode, arrays of the step number, the reference
point, heading, commanded steering and speed, progress, sim time and status.

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
(:func:`drx.calibration.step_jitter.step_length_jitter`: the logged time leaves 1.7-2.1
times the residual). :attr:`LoggedEpisode.step_times` therefore gives every sane
step the episode's mean length; :mod:`drx.calibration.step_jitter` measures the car's
own step-to-step variation from the distances instead.
"""

from __future__ import annotations

import csv
import functools
import math
import re
from collections import Counter
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np

from drx.errors import DrxError
from drx.sim.episode_status import EpisodeStatus

TRACE_PREFIX = "SIM_TRACE_LOG:"
MIN_DT, MAX_DT = 0.02, 0.2  # [s] logged step lengths outside this are gaps in the log, not steps
NOMINAL_STEP = 1.0 / 15.0  # [s] DeepRacer's step at 15 Hz
# deepracer-simapp's StepMetrics, in its order (the module docstring's table).
BASE_COLUMNS = (
    "episode", "steps", "X", "Y", "yaw", "steer", "throttle", "action", "reward", "done",
    "all_wheels_on_track", "progress", "closest_waypoint", "track_len", "tstamp", "episode_status",
)  # fmt: skip
LATER_COLUMNS = ("pause_duration", "obstacle_crash_counter", "wall_clock")
# A header-less row's columns by its count of fields: 16 -> BASE_COLUMNS, 17 -> + pause_duration, ...
ROW_LAYOUTS: dict[int, tuple[str, ...]] = {
    len(BASE_COLUMNS) + k: BASE_COLUMNS + LATER_COLUMNS[:k] for k in range(len(LATER_COLUMNS) + 1)
}
# The numeric columns kept, in the order of a parsed row's values; then the status.
_NUMERIC = ("episode", "steps", "X", "Y", "yaw", "steer", "throttle", "progress", "tstamp")
REQUIRED_COLUMNS = (*_NUMERIC, "episode_status")
# deepracer-utils' renames (DeepRacerLog), so a trace it saved reads too; a header's names match whatever
# their case (its x, y are X, Y).
_ALIASES = {"steering_angle": "steer", "speed": "throttle", "on_track": "all_wheels_on_track"}
_KNOWN = {c.lower(): c for c in BASE_COLUMNS + LATER_COLUMNS} | _ALIASES
_TRACE_LINE = re.compile(re.escape(TRACE_PREFIX) + r"([^\r\n]*)")
_BRACKETED = re.compile(r"\[[^\[\]\r\n]*\]")  # a continuous action, "[a, b]" or "[a b]"
_STATUS = re.compile(r"[A-Za-z][A-Za-z_]*")
_EXAMPLES = 3  # malformed rows named in a message

Layout = Literal["csv", "robomaker"]


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
    :param steps: the logged step number per row (``steps``); 1, 2, ... when not given.
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
    steps: np.ndarray = field(default_factory=lambda: np.empty(0))

    def __post_init__(self) -> None:
        if len(self.steps) == 0 and len(self.x):  # an episode made by hand: its rows are its steps
            object.__setattr__(self, "steps", np.arange(1.0, len(self.x) + 1.0))

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


@dataclass(frozen=True)
class MalformedRow:
    """A trace row that does not read: ``line`` (1-based, in the file) and why (``14 fields``)."""

    line: int
    reason: str


@dataclass(frozen=True)
class TraceFile:
    """One sim-trace CSV or robomaker log as read (:func:`read_trace_file`).

    :param path: the file.
    :param layout: ``csv`` (a header names the columns) or ``robomaker`` (``SIM_TRACE_LOG`` lines, or
        header-less rows, named by their count of fields: :data:`ROW_LAYOUTS`).
    :param columns: the header's columns (``csv``), or those of the longest layout read (``robomaker``).
    :param field_counts: rows read per count of fields (the bracketed action counted as one).
    :param rows: the rows read, every status (the episodes' rows in all).
    :param malformed: the rows that did not read, in file order.
    :param episodes: the episodes, in file order.
    """

    path: str
    layout: Layout
    columns: tuple[str, ...]
    field_counts: Mapping[int, int]
    rows: int
    malformed: tuple[MalformedRow, ...]
    episodes: tuple[LoggedEpisode, ...]

    def malformed_note(self) -> str | None:
        """One sentence on the malformed rows (``None`` when there are none), e.g. ``2 of the 5,000
        trace rows of robomaker.log do not read and were skipped (line 12: 14 fields; ...)``."""
        if not self.malformed:
            return None
        return f"{_count_of_malformed(self)} ({_examples(self.malformed)})."


def read_trace_file(path: str | Path) -> TraceFile:
    """One sim-trace CSV or robomaker log, every layout DeepRacer has written (the module docstring).

    :raises DrxError: when the file is missing, holds no trace rows, has a header without the
        columns a replay reads, or none of its rows reads.
    """
    p = Path(path)
    if not p.is_file():
        raise DrxError(f"DeepRacer log {str(p)!r} does not exist or is not a file; give a sim-trace CSV "
                       "or a robomaker log.")  # fmt: skip
    text = p.read_text(encoding="utf-8", errors="replace")
    layout: Layout = "robomaker"
    index = {name: i for i, name in enumerate(BASE_COLUMNS)}
    counts: Iterable[int] = ROW_LAYOUTS
    candidates: list[tuple[int, str]]  # (where: a character offset for a log, a line number for a CSV, row)
    if TRACE_PREFIX in text:
        candidates = [(m.start(), m.group(1)) for m in _TRACE_LINE.finditer(text)]
    else:
        lines = text.lstrip("\ufeff").split("\n")
        first = next((i for i, line in enumerate(lines) if line.strip()), len(lines))
        head = lines[first].strip() if first < len(lines) else ""
        header = _header_index(head, p)
        if header is not None:
            layout, index, counts = "csv", header, (len(head.split(",")),)
            rows_from, repeated = first + 1, head  # a header repeated (CSVs joined) is no row
        else:
            rows_from, repeated = (first if _reads_as_row(head) else len(lines)), None
        candidates = [
            (i + 1, line.rstrip("\r")) for i, line in enumerate(lines[rows_from:], start=rows_from)
            if line.strip() and line.strip() != repeated
        ]  # fmt: skip
    if not candidates:
        raise DrxError(f"{str(p)!r} holds no DeepRacer trace rows; give a sim-trace CSV (with its header) "
                       f"or a robomaker log with {TRACE_PREFIX} lines.")  # fmt: skip
    values, statuses, seen, bad = _parse(candidates, index, frozenset(counts))
    if layout == "robomaker":  # where = a character offset (rising): its line number, counted on
        line, counted, numbered = 1, 0, []
        for where, reason in bad:
            line += text.count("\n", counted, where)
            counted = where
            numbered.append((line, reason))
        bad = numbered
    malformed = tuple(MalformedRow(line, reason) for line, reason in bad)
    if not statuses:
        raise DrxError(f"none of the {len(candidates):,} trace rows of {str(p)!r} reads as a DeepRacer "
                       f"sim-trace row ({_examples(malformed)}); give the log as DeepRacer wrote "
                       "it.")  # fmt: skip
    columns = tuple(sorted(index, key=index.__getitem__)) if layout == "csv" else ROW_LAYOUTS[max(seen)]
    return TraceFile(
        path=str(p), layout=layout, columns=columns, field_counts=dict(sorted(seen.items())),
        rows=len(statuses), malformed=malformed, episodes=tuple(_episodes(values, statuses, str(p))),
    )  # fmt: skip


def read_trace(path: str | Path) -> list[LoggedEpisode]:
    """The episodes of one sim-trace CSV or robomaker log, in file order (:func:`read_trace_file`).

    :raises DrxError: when the file is missing or holds no trace rows that read.
    """
    return list(read_trace_file(path).episodes)


def read_traces(paths: list[str | Path]) -> list[LoggedEpisode]:
    """The episodes of several files (see :func:`read_trace`), one list."""
    out: list[LoggedEpisode] = []
    for path in paths:
        out.extend(read_trace(path))
    return out


def read_trace_files(paths: Iterable[str | Path]) -> list[TraceFile]:
    """Several files (see :func:`read_trace_file`), in the order given."""
    return [read_trace_file(path) for path in paths]


def _header_index(line: str, path: Path) -> dict[str, int] | None:
    """``{column: position}`` when ``line`` is a sim-trace header naming every column a replay reads,
    ``None`` when it is no header at all.

    :raises DrxError: for a header (it names ``episode`` and ``steps``) that lacks some of them.
    """
    names = [_KNOWN.get(n.strip().strip('"').lower(), n.strip()) for n in line.split(",")]
    index: dict[str, int] = {}
    for i, name in enumerate(names):
        index.setdefault(name, i)
    missing = [c for c in REQUIRED_COLUMNS if c not in index]
    if not missing:
        return index
    if "episode" in index and "steps" in index:
        raise DrxError(f"the header of {str(path)!r} lacks the column{'s' if len(missing) > 1 else ''} "
                       f"{', '.join(missing)}; give a DeepRacer sim-trace CSV, whose header names "
                       f"{', '.join(REQUIRED_COLUMNS)}.")  # fmt: skip
    return None


def _reads_as_row(line: str) -> bool:
    """Whether a header-less file's first line is a sim-trace row (then every line is one)."""
    fields = _fields(line)
    return len(fields) in ROW_LAYOUTS and all(_is_number(fields[i]) for i in (0, 1, 2, 3))


def _fields(row: str) -> list[str]:
    """The fields of one row, a bracketed continuous action (``[a, b]``, ``[a b]``) as one field."""
    if "[" in row:
        row = _BRACKETED.sub(_without_commas, row)
    if '"' in row:  # quoted by a CSV writer (drx's own traces): let csv unquote it
        return next(csv.reader([row]))
    return row.split(",")


def _without_commas(match: re.Match[str]) -> str:
    return match.group().replace(",", " ")


def _parse(
    candidates: list[tuple[int, str]], index: Mapping[str, int], counts: frozenset[int]
) -> tuple[list[list[float]], list[str], Counter[int], list[tuple[int, str]]]:
    """The rows that read: their :data:`_NUMERIC` values and statuses, the rows per count of fields;
    and ``(where, why)`` of those that do not."""
    at = [index[c] for c in _NUMERIC]
    status_at = index["episode_status"]
    values: list[list[float]] = []
    statuses: list[str] = []
    seen: Counter[int] = Counter()
    bad: list[tuple[int, str]] = []
    isfinite, status_word = math.isfinite, _STATUS.fullmatch
    lo, hi = min(counts), max(counts)
    expected = f"{lo} to {hi}" if hi - lo + 1 == len(counts) > 2 else " or ".join(map(str, sorted(counts)))
    for where, row in candidates:
        fields = _fields(row)
        n = len(fields)
        if n not in counts:
            bad.append((where, f"{n} fields, not {expected}"))
            continue
        try:
            numbers = [float(fields[i]) for i in at]
        except ValueError:
            name, i = next((c, i) for c, i in zip(_NUMERIC, at, strict=True) if not _is_number(fields[i]))
            bad.append((where, f"{name} {fields[i].strip()[:20]!r} is not a number"))
            continue
        if not all(map(isfinite, numbers)):
            name = next(c for c, v in zip(_NUMERIC, numbers, strict=True) if not isfinite(v))
            bad.append((where, f"{name} is {fields[at[_NUMERIC.index(name)]].strip()}, not a finite number"))
            continue
        if not numbers[0].is_integer():
            bad.append((where, f"episode {fields[at[0]].strip()} is not a whole number"))
            continue
        status = fields[status_at].strip()
        if status_word(status) is None:
            bad.append((where, f"episode_status {status[:20]!r} is not a status word"))
            continue
        values.append(numbers)
        statuses.append(status)
        seen[n] += 1
    return values, statuses, seen, bad


def _is_number(s: str) -> bool:
    try:
        float(s)
    except ValueError:
        return False
    return True


def _episodes(values: list[list[float]], statuses: list[str], source: str) -> list[LoggedEpisode]:
    """One :class:`LoggedEpisode` per run of rows with the same episode number and rising step numbers:
    a number that comes back later, or steps that start again (a restarted job), start another."""
    a = np.asarray(values, dtype=np.float64).reshape(-1, len(_NUMERIC))
    new = (np.diff(a[:, 0]) != 0) | (np.diff(a[:, 1]) < 0)
    starts = [0, *(np.flatnonzero(new) + 1).tolist(), len(a)]
    out = []
    for lo, hi in zip(starts[:-1], starts[1:], strict=True):
        e = a[lo:hi]
        out.append(
            LoggedEpisode(
                episode=int(e[0, 0]), x=e[:, 2], y=e[:, 3], yaw=np.radians(e[:, 4]), steer=e[:, 5],
                throttle=e[:, 6], progress=e[:, 7], tstamp=e[:, 8], status=tuple(statuses[lo:hi]),
                source=source, steps=e[:, 1],
            )
        )  # fmt: skip
    return out


def _count_of_malformed(trace: TraceFile) -> str:
    total = trace.rows + len(trace.malformed)
    bad = len(trace.malformed)
    verbs = "does not read and was" if bad == 1 else "do not read and were"
    return f"{bad:,} of the {total:,} trace rows of {trace.path} {verbs} skipped"


def _examples(malformed: tuple[MalformedRow, ...]) -> str:
    shown = "; ".join(f"line {m.line}: {m.reason}" for m in malformed[:_EXAMPLES])
    more = len(malformed) - _EXAMPLES
    return shown + (f"; {more:,} more" if more > 0 else "")


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
