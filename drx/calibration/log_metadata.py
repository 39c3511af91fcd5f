"""What a DeepRacer log says of how it was recorded: the simulator version, the action space.

**The simulator.** drx's car is fitted per DeepRacer simulator version (deepracer-simapp;
:mod:`drx.sim.car_calibration` ``SIMULATORS``). A log names the version that recorded it in one of four
places, read in this order:

1. **the robomaker log itself**: at start-up deepracer-simapp logs the model's metadata as it parsed it
   (``bundle/markov/boto/s3/files/model_metadata.py``, ``parse_model_metadata``), e.g. ``Sensor list
   ['FRONT_FACING_CAMERA'], network DEEP_CONVOLUTIONAL_NETWORK_SHALLOW, simapp_version 5.0,
   training_algorithm clipped_ppo, ...``. The line comes before the first ``SIM_TRACE_LOG`` step
   (line 20-60 of the shared logs, again near line 150 in deepracer-for-cloud's); only the first
   :data:`HEADER_BYTES` of a log are read, and reading stops at the first match.
2. **the console's sagemaker log beside it**: the console's log download holds, per training job,
   ``training-<start time>-<job id>-robomaker.log`` and ``training-<start time>-<job id>-sagemaker.log``
   (their start times a second or two apart, so they are matched by the job id; the console 2025 logs
   were saved as ``.txt`` too: :func:`sagemaker_log_of`). The sagemaker side prints the same line.
3. **deepracer-log-guru's** ``<log>.meta.json`` beside the log: ``environment.simulation_version``
   (``"5.0"``), which log-guru takes from that same line.
4. **the console's** ``model_metadata.json`` in its log layout (``sample-console-logs/model/
   model_metadata.json`` beside ``sample-console-logs/sim-trace/training/training-simtrace/*.csv``):
   ``"version": "4.0"``, the simapp version the model was made for. It is looked for, as
   ``model_metadata.json`` or ``model/model_metadata.json``, in the log's folder and the folders
   above it, :data:`MODEL_METADATA_LEVELS` folders in all (the console's evaluation traces sit five
   folders below it).

All of them carry the model's ``model_metadata.json`` ``version``: simapp prints ``simapp_version`` from
it. A version drx has no car for (``3.0``, ``6.0``) gets the nearest version it has, and says so (for
version 6, why: :mod:`drx.calibration.simulators`).

**The action space** (:func:`action_space_of_log`, :class:`LogActionSpace`) is read from the same four
places: simapp logs the model's ``action_space`` as it loaded it, ``Action space from file: {...}``
(``load_action_space`` in ``bundle/markov/agent_ctrl/utils.py``), in the robomaker log (simapp 5) and
the console's sagemaker log; log-guru's ``.meta.json`` has ``action_space``; ``model_metadata.json`` has
``action_space`` and ``action_space_type``. A continuous space is its steering and speed ranges, a
discrete one its actions.
"""

from __future__ import annotations

import ast
import json
import math
import os
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from drx.calibration.simulators import nearest_car_reason
from drx.errors import DrxError
from drx.sim.car_calibration import DEFAULT_SIMULATOR, SIMULATORS

HEADER_BYTES = 1 << 20  # a robomaker log's start-up lines: the first MiB at most
MODEL_METADATA_LEVELS = 5  # the log's folder and the four above it
_CHUNK = 1 << 16
_LONGEST_LINE = 1 << 16  # [bytes] of a line kept while the rest of it is read
_SIMAPP_LINE = re.compile(rb"simapp_version[\s:=]+['\"]?(\d+(?:\.\d+)*)")
_ACTION_SPACE_LINE = re.compile(rb"Action space from file:[ \t]*([^\r\n]*)")
_VERSION = re.compile(r"v?(\d+)(?:\.\d+)*")
# The console's log download: <job>-<start time>-<job id>-robomaker.log beside ...-sagemaker.log.
_CONSOLE_LOG = re.compile(
    r"(?P<job>[A-Za-z]+)-(?P<time>\d{14})-(?P<id>.+)-(?P<side>robomaker|sagemaker)\.\w+"
)

Kind = Literal["robomaker", "sagemaker", "meta.json", "model_metadata"]
ChosenBy = Literal["user", "logs", "default"]


@dataclass(frozen=True)
class LogSimulator:
    """What one log says of the DeepRacer simulator that recorded it (:func:`simulator_of_log`).

    :param log: the log.
    :param version: drx's car for it, a key of ``SIMULATORS`` (the nearest one for a version drx has no
        car for); ``None`` when the log says nothing.
    :param logged: the version as written, e.g. ``"5.0"``.
    :param kind: where it was found: ``robomaker`` (the log's ``simapp_version`` line), ``sagemaker``
        (the same line in the console's sagemaker log beside it), ``meta.json`` (log-guru's
        ``environment.simulation_version``), ``model_metadata`` (the console's ``version``).
    :param where: the file it was found in (the log itself for ``robomaker``).
    :param reason: one phrase saying so, e.g. ``simapp_version 5.0 in the robomaker log``, or why
        nothing was found.
    """

    log: Path
    version: str | None
    logged: str | None = None
    kind: Kind | None = None
    where: Path | None = None
    reason: str = ""

    @property
    def exact(self) -> bool:
        """Whether drx has a car for the logged version itself (not only a nearest one)."""
        return self.logged is not None and _major(self.logged) == _major(self.version or "")


@dataclass(frozen=True)
class SimulatorChoice:
    """The car a replay of some logs uses, and why (:func:`choose_simulator`).

    :param version: the simulator version whose car replays them (a key of ``SIMULATORS``).
    :param chosen_by: ``user`` (``--simulator``), ``logs`` (their metadata) or ``default`` (neither).
    :param source: one phrase saying why, e.g. ``simapp_version 5.0 in 8 robomaker logs``.
    :param in_logs: the versions the logs' metadata names, sorted (empty when they say nothing).
    :param note: when the user's choice contradicts the logs' metadata, one sentence saying so.
    :param logs: what each log says.
    """

    version: str
    chosen_by: ChosenBy
    source: str
    in_logs: tuple[str, ...] = ()
    note: str | None = None
    logs: tuple[LogSimulator, ...] = field(default=(), repr=False)


def known_simulators() -> list[str]:
    """The simulator versions drx has a car for, oldest first (``["4", "5", "6"]``)."""
    return sorted(SIMULATORS, key=int)


def check_simulator(value: str) -> str:
    """The simulator version a user named (``5``, ``5.0``, ``v5``), as a key of ``SIMULATORS``.

    :raises DrxError: for a version drx has no car for, or not a version at all.
    """
    major = _major(value)
    if major is None or str(major) not in SIMULATORS:
        *older, newest = known_simulators()
        known = f"{', '.join(older)} or {newest}" if older else newest
        raise DrxError(f"--simulator {value} is not a DeepRacer simulator version drx has a car for; use "
                       f"{known}.")  # fmt: skip
    return str(major)


def car_for_version(logged: str) -> str | None:
    """drx's car for a logged simulator version: ``"5.0"`` -> ``"5"``; a version drx has no car for
    gets the nearest one (``"3.0"`` -> ``"4"``, ``"7.0"`` -> ``"6"``, the newer on a tie); ``None`` when
    ``logged`` is not a version."""
    major = _major(logged)
    if major is None:
        return None
    return str(min((int(k) for k in SIMULATORS), key=lambda k: (abs(k - major), -k)))


def simulator_of_log(path: str | Path) -> LogSimulator:
    """Which DeepRacer simulator recorded the log at ``path``, from its metadata (the module docstring:
    deepracer-simapp's ``simapp_version`` line in a robomaker log, deepracer-log-guru's
    ``<log>.meta.json``, the console's ``model_metadata.json``), or ``version=None`` with the reason.
    Never raises for a missing or unreadable file: reading the log itself reports that."""
    return _simulator_of_log(Path(path), {})


def choose_simulator(logs: Sequence[str | Path], requested: str | None = None) -> SimulatorChoice:
    """The car to replay ``logs`` with: ``requested`` (``--simulator``) if given, else the version the
    logs' metadata names (:func:`simulator_of_log`), else ``DEFAULT_SIMULATOR``.

    A requested version the logs contradict is used, with a :attr:`SimulatorChoice.note` saying so.

    :raises DrxError: when ``requested`` is not a version drx has a car for, or when, with no
        ``requested``, the logs name different versions.
    """
    version = check_simulator(requested) if requested is not None else None
    cache: dict[Path, tuple[Path, Any] | None] = {}
    found = tuple(_simulator_of_log(Path(p), cache) for p in logs)
    said = [f for f in found if f.version is not None]
    by_version: dict[str, list[LogSimulator]] = {}
    for f in said:
        by_version.setdefault(str(f.version), []).append(f)
    in_logs = tuple(sorted(by_version, key=int))
    if version is not None:
        if not in_logs:
            return SimulatorChoice(version, "user", "chosen with --simulator; the logs name no simulator",
                                   in_logs, None, found)  # fmt: skip
        if in_logs == (version,):
            source = f"chosen with --simulator; the logs agree: {_describe(said, len(found))}"
            return SimulatorChoice(version, "user", source, in_logs, None, found)
        if len(in_logs) == 1:
            note = (f"the logs name simulator {in_logs[0]} ({_describe(said, len(found))}); replayed with "
                    f"simulator {version}'s car as --simulator asked.")  # fmt: skip
        else:
            note = (f"the logs name different simulators: {_disagreement(by_version)}; "
                    f"replayed all of them with simulator {version}'s car as --simulator asked.")  # fmt: skip
        return SimulatorChoice(version, "user", "chosen with --simulator", in_logs, note, found)
    if not in_logs:
        return SimulatorChoice(
            DEFAULT_SIMULATOR, "default",
            f"no simulator version in the logs; used simulator {DEFAULT_SIMULATOR}'s car (pass --simulator "
            "to choose)", in_logs, None, found,
        )  # fmt: skip
    if len(in_logs) > 1:
        choices = " or ".join(in_logs)
        which = _disagreement(by_version)
        raise DrxError(f"the logs come from different DeepRacer simulators: {which}; "
                       f"pass --simulator {choices} to replay them all with one car, or replay them "
                       "separately.")  # fmt: skip
    return SimulatorChoice(in_logs[0], "logs", _describe(said, len(found)), in_logs, None, found)


# --- the action space --------------------------------------------------------------------------

SpaceKind = Literal["continuous", "discrete"]
SPEED_TOLERANCE = 0.006  # [m/s] the logs print the commanded speed to 2 decimals


@dataclass(frozen=True)
class LogActionSpace:
    """The action space of the model that drove a log, as the log's metadata says
    (:func:`action_space_of_log`).

    :param kind: ``continuous`` (any steering and speed within the ranges) or ``discrete`` (the actions).
    :param steering: ``(low, high)`` steering [deg], + = left (a discrete space's extremes).
    :param speed: ``(low, high)`` speed [m/s] (a discrete space's extremes).
    :param actions: a discrete space's ``(steering deg, speed m/s)`` in index order; ``()`` for a
        continuous one.
    :param found_in: where it was found, as :attr:`LogSimulator.kind`: ``robomaker`` or ``sagemaker``
        (simapp's ``Action space from file`` line), ``meta.json``, ``model_metadata``.
    :param where: the file it was found in.
    """

    kind: SpaceKind
    steering: tuple[float, float]
    speed: tuple[float, float]
    actions: tuple[tuple[float, float], ...] = ()
    found_in: Kind | None = None
    where: Path | None = None

    @property
    def speeds(self) -> tuple[float, ...]:
        """A discrete space's distinct speeds [m/s], slowest first (``()`` for a continuous one)."""
        return tuple(sorted({speed for _, speed in self.actions}))

    def allows_speed(self, speed: float, tolerance: float = SPEED_TOLERANCE) -> bool:
        """Whether a logged speed command [m/s] is one the space holds, to within ``tolerance``: inside
        the range (continuous), at one of the actions' speeds (discrete)."""
        if self.kind == "discrete":
            return any(abs(speed - s) <= tolerance for s in self.speeds)
        return self.speed[0] - tolerance <= speed <= self.speed[1] + tolerance

    def describe(self) -> str:
        """One phrase, e.g. ``continuous, steering -20 to 30 deg, speed 1.3 to 4 m/s`` or ``discrete, 7
        actions: steering -30 to 30 deg, speeds 1, 1.5, 2, 4 m/s`` (3 significant digits)."""
        steering = f"steering {self.steering[0]:.3g} to {self.steering[1]:.3g} deg"
        if self.kind == "continuous":
            return f"continuous, {steering}, speed {self.speed[0]:.3g} to {self.speed[1]:.3g} m/s"
        speeds = ", ".join(f"{s:.3g}" for s in self.speeds)
        return f"discrete, {len(self.actions)} actions: {steering}, speeds {speeds} m/s"

    @property
    def source(self) -> str:
        """Where it was found, one phrase: ``Action space from file in training-...-sagemaker.log``."""
        name = _shown(self.where) if self.where is not None else "the log"
        if self.found_in in ("robomaker", "sagemaker"):
            return f"Action space from file in {name}"
        return f"action_space in {name}"

    def key(self) -> tuple[Any, ...]:
        """What makes two logs' action spaces the same one (not where they were found)."""
        return (self.kind, self.steering, self.speed, self.actions)

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly: kind, ranges, actions and where it was found."""
        return {
            "kind": self.kind,
            "steering_deg": list(self.steering),
            "speed_mps": list(self.speed),
            "actions": [list(a) for a in self.actions],
            "found_in": self.found_in,
            "where": str(self.where) if self.where is not None else None,
        }


def action_space_of_log(path: str | Path) -> LogActionSpace | None:
    """The action space of the model that drove the log at ``path`` (the module docstring: simapp's
    ``Action space from file`` line in the robomaker log or the console's sagemaker log beside it,
    log-guru's ``<log>.meta.json``, the nearest ``model_metadata.json``), or ``None`` when none of them
    says. Never raises: reading the log itself reports a missing or unreadable file."""
    return _action_space_of_log(Path(path), {})


def action_spaces_of_logs(logs: Sequence[str | Path]) -> list[LogActionSpace | None]:
    """:func:`action_space_of_log` of each log (each ``model_metadata.json`` read once)."""
    cache: dict[Path, tuple[Path, Any] | None] = {}
    return [_action_space_of_log(Path(p), cache) for p in logs]


def _action_space_of_log(log: Path, cache: dict[Path, tuple[Path, Any] | None]) -> LogActionSpace | None:
    if not log.is_file():
        return None
    sagemaker = sagemaker_log_of(log)
    heads: tuple[tuple[Kind, Path | None], ...] = (("robomaker", log), ("sagemaker", sagemaker))
    for found_in, where in heads:
        if where is None:
            continue
        match = _head_match(where, _ACTION_SPACE_LINE)
        space = _parse_space(_literal(match.group(1)) if match else None, found_in, where)
        if space is not None:
            return space
    meta = log.with_name(log.name + ".meta.json")
    if meta.is_file():
        data = _read_json(meta)
        space = _parse_space(data.get("action_space") if isinstance(data, dict) else None, "meta.json", meta)
        if space is not None:
            return space
    for folder in _above(log.absolute().parent):
        if folder not in cache:
            cache[folder] = _model_metadata_in(folder)
        hit = cache[folder]
        if hit is not None:
            where, data = hit
            value = data.get("action_space") if isinstance(data, dict) else None
            kind = data.get("action_space_type") if isinstance(data, dict) else None
            return _parse_space(value, "model_metadata", where, kind)
    return None


def _literal(text: bytes) -> Any:
    """The Python literal simapp printed (``{'steering_angle': {'high': 30, ...}}``), or ``None``."""
    try:
        return ast.literal_eval(text.decode("utf-8", errors="replace").strip())
    except (ValueError, SyntaxError, TypeError, MemoryError, RecursionError):
        return None


def _parse_space(value: Any, found_in: Kind, where: Path, kind: Any = None) -> LogActionSpace | None:
    """An action space from ``model_metadata.json``'s ``action_space`` (``{steering_angle: {low, high},
    speed: {low, high}}`` or a list of ``{steering_angle, speed}``) or log-guru's (``{type, actions,
    min_speed, max_speed, max_left_steering, max_right_steering}``); ``None`` when it is neither."""
    if isinstance(value, dict) and "type" in value:  # log-guru's
        if str(value["type"]).lower() == "continuous":
            steering = _pair(value.get("max_right_steering"), value.get("max_left_steering"))
            speed = _pair(value.get("min_speed"), value.get("max_speed"))
            if steering is None or speed is None:
                return None
            return LogActionSpace("continuous", steering, speed, (), found_in, where)
        value = value.get("actions")
    if isinstance(value, dict) and str(kind or "continuous").lower() == "continuous":
        steer, speed_range = value.get("steering_angle"), value.get("speed")
        if not isinstance(steer, dict) or not isinstance(speed_range, dict):
            return None
        steering = _pair(steer.get("low"), steer.get("high"))
        speed = _pair(speed_range.get("low"), speed_range.get("high"))
        if steering is None or speed is None:
            return None
        return LogActionSpace("continuous", steering, speed, (), found_in, where)
    if isinstance(value, list) and value and str(kind or "discrete").lower() == "discrete":
        pairs = [
            _pair(a.get("steering_angle"), a.get("speed")) if isinstance(a, dict) else None for a in value
        ]
        actions = tuple(a for a in pairs if a is not None)
        if len(actions) < len(pairs):
            return None
        steers, speeds = [a[0] for a in actions], [a[1] for a in actions]
        steering, speed = (min(steers), max(steers)), (min(speeds), max(speeds))
        return LogActionSpace("discrete", steering, speed, actions, found_in, where)
    return None


def _pair(a: Any, b: Any) -> tuple[float, float] | None:
    """``(a, b)`` as finite floats (``a <= b`` is not asked: a discrete action is no range), or ``None``."""
    try:
        x, y = float(a), float(b)
    except (TypeError, ValueError):
        return None
    return (x, y) if math.isfinite(x) and math.isfinite(y) else None


# --- reading one log ---------------------------------------------------------------------------


def _simulator_of_log(log: Path, cache: dict[Path, tuple[Path, Any] | None]) -> LogSimulator:
    if not log.is_file():
        return LogSimulator(log, None, reason=f"{_shown(log)} is not a file")
    logged = _simapp_line(log)
    if logged is not None:
        return _found(log, logged, "robomaker", log, f"simapp_version {logged} in the robomaker log")
    sagemaker = sagemaker_log_of(log)
    logged = _simapp_line(sagemaker) if sagemaker is not None else None
    if sagemaker is not None and logged is not None:
        return _found(log, logged, "sagemaker", sagemaker, f"simapp_version {logged} in {sagemaker.name}")
    unreadable = []
    meta = log.with_name(log.name + ".meta.json")
    if meta.is_file():
        data = _read_json(meta)
        value = _get(data, "environment", "simulation_version")
        if value is not None:
            logged = _as_text(value)
            return _found(log, logged, "meta.json", meta,
                          f"environment.simulation_version {logged} in {meta.name}")  # fmt: skip
        if data is None:
            unreadable.append(meta)
    for folder in _above(log.absolute().parent):
        if folder not in cache:
            cache[folder] = _model_metadata_in(folder)
        hit = cache[folder]
        if hit is None:
            continue
        where, data = hit
        value = _get(data, "version")
        if value is not None:
            logged = _as_text(value)
            return _found(log, logged, "model_metadata", where, f"version {logged} in {_shown(where)}")
        if data is None:
            unreadable.append(where)
        break  # the nearest model_metadata.json is the log's model's, version or not
    reason = (f"no simulator version in {_shown(log)} (no simapp_version line, no {meta.name}, no "
              f"model_metadata.json up to {MODEL_METADATA_LEVELS} folders up)")  # fmt: skip
    if unreadable:
        reason += "; " + ", ".join(_shown(p) for p in unreadable) + " is not valid JSON"
    return LogSimulator(log, None, reason=reason)


def _found(log: Path, logged: str, kind: Kind, where: Path, reason: str) -> LogSimulator:
    version = car_for_version(logged)
    if version is None:
        return LogSimulator(log, None, logged, kind, where, f"{reason}, which is not a version")
    return LogSimulator(log, version, logged, kind, where, reason)


def _simapp_line(log: Path) -> str | None:
    """The ``simapp_version`` in a robomaker log's first :data:`HEADER_BYTES`, reading no further than
    the line holding it; ``None`` for a sim-trace CSV (its first line is the ``episode,...`` header)."""
    match = _head_match(log, _SIMAPP_LINE)
    return match.group(1).decode("ascii") if match else None


def _head_match(log: Path, pattern: re.Pattern[bytes]) -> re.Match[bytes] | None:
    """The first match of ``pattern`` in the first :data:`HEADER_BYTES` of ``log``, read
    :data:`_CHUNK` at a time and no further than the chunk holding its end (a match that ends where the
    bytes read end is read on: the line may go on); ``None`` for a sim-trace CSV, whose first line is
    its header, or an unreadable file."""
    try:
        with log.open("rb") as f:
            buffer = f.read(min(_CHUNK, HEADER_BYTES))
            if _is_csv_head(buffer):
                return None
            read = len(buffer)
            while True:
                match = pattern.search(buffer)
                if match and match.end() < len(buffer):  # not cut at the chunk's end ("5" of "5.0")
                    return match
                more = f.read(min(_CHUNK, HEADER_BYTES - read)) if read < HEADER_BYTES else b""
                if not more:
                    return match
                read += len(more)
                # keep the last, unfinished line (bounded): a line split across two chunks is still found
                buffer = buffer[buffer.rfind(b"\n") + 1 :][-_LONGEST_LINE:] + more
    except OSError:
        return None


def _is_csv_head(buffer: bytes) -> bool:
    first = buffer.lstrip(b"\xef\xbb\xbf \t\r\n").split(b"\n", 1)[0].lower()
    return first.startswith(b"episode,") or (b"episode_status" in first and b"sim_trace_log" not in first)


def sagemaker_log_of(log: Path) -> Path | None:
    """The console's sagemaker log of the same training job as the robomaker log ``log``, beside it:
    ``training-20251031193351-k8lvx-yPSy-6ZpPsayBIow-sagemaker.log`` for
    ``training-20251031193352-k8lvx-yPSy-6ZpPsayBIow-robomaker.log`` (the start times differ by a
    second or two, so the job id after them decides; of several, the one started nearest), any
    extension (``.log``, ``.txt``); ``None`` when there is none or ``log`` is not named so."""
    named = _CONSOLE_LOG.fullmatch(log.name)
    if named is None or named["side"] != "robomaker":
        return None
    try:
        siblings = [p for p in log.parent.glob(f"{named['job']}-*-sagemaker.*") if p.is_file()]
    except OSError:
        return None
    same_job = []
    for sibling in siblings:
        other = _CONSOLE_LOG.fullmatch(sibling.name)
        if other is not None and other["id"] == named["id"] and other["side"] == "sagemaker":
            same_job.append((abs(int(other["time"]) - int(named["time"])), sibling.name, sibling))
    return min(same_job)[2] if same_job else None


def _model_metadata_in(folder: Path) -> tuple[Path, Any] | None:
    """``(path, parsed JSON or None when unreadable)`` of ``folder``'s ``model_metadata.json`` or
    ``model/model_metadata.json``, or ``None`` when it has neither."""
    for candidate in (folder / "model_metadata.json", folder / "model" / "model_metadata.json"):
        if candidate.is_file():
            return candidate, _read_json(candidate)
    return None


def _above(folder: Path) -> list[Path]:
    return [folder, *folder.parents][:MODEL_METADATA_LEVELS]


def _read_json(path: Path) -> Any:
    try:
        return json.loads(path.read_text(encoding="utf-8", errors="replace"))
    except (OSError, ValueError):
        return None


def _get(data: Any, *keys: str) -> Any:
    for key in keys:
        if not isinstance(data, dict):
            return None
        data = data.get(key)
    return None if isinstance(data, bool) or not isinstance(data, str | int | float) else data


def _as_text(value: str | int | float) -> str:
    if isinstance(value, float):
        return f"{value:g}"
    return value.strip() if isinstance(value, str) else str(value)


def _major(value: str) -> int | None:
    match = _VERSION.fullmatch(str(value).strip().lower())
    return int(match.group(1)) if match else None


# --- saying it ---------------------------------------------------------------------------------


def _describe(said: list[LogSimulator], total: int) -> str:
    """One phrase for what ``said`` (the logs, of ``total``, that name a version) say: grouped by where
    it was found, e.g. ``simapp_version 5.0 in 8 robomaker logs; 2 of the 10 logs name no simulator``."""
    groups: dict[tuple[str, str, str], list[LogSimulator]] = {}
    for f in said:
        shared_file = str(f.where) if f.kind == "model_metadata" else ""
        groups.setdefault((str(f.kind), str(f.logged), shared_file), []).append(f)
    phrases = []
    for (kind, logged, _), members in groups.items():
        n, first = len(members), members[0]
        if n > 1 and kind == "robomaker":
            phrases.append(f"simapp_version {logged} in {n} robomaker logs")
        elif n > 1 and kind == "sagemaker":
            phrases.append(f"simapp_version {logged} in the sagemaker logs beside {n} robomaker logs")
        elif n > 1 and kind == "meta.json":
            phrases.append(f"environment.simulation_version {logged} in the {n} logs' .meta.json files")
        elif kind == "robomaker" and total > 1:
            phrases.append(f"{first.reason} {first.log.name}")
        else:
            phrases.append(first.reason)
    if len(said) < total:
        silent = total - len(said)
        phrases.append(f"{silent} of the {total} logs {'names' if silent == 1 else 'name'} no simulator")
    for logged, version in dict.fromkeys((str(f.logged), str(f.version)) for f in said if not f.exact):
        reason = nearest_car_reason(_major(logged) or "")
        phrases.append(reason or f"drx has no car for simulator {logged}; the nearest it has is {version}")
    return "; ".join(phrases)


def _disagreement(by_version: dict[str, list[LogSimulator]]) -> str:
    """``4 for a.csv and 27 more (version 4.0 in ...), 5 for b.log (simapp_version 5.0 in ...)``: each
    version, the first log naming it as the user gave it, and where it was found."""
    parts = []
    for version in sorted(by_version, key=int):
        members = by_version[version]
        names = str(members[0].log) + (f" and {len(members) - 1} more" if len(members) > 1 else "")
        parts.append(f"{version} for {names} ({_describe(members, len(members))})")
    return ", ".join(parts)


def _shown(path: Path) -> str:
    """``path`` relative to the working folder (``model/model_metadata.json``,
    ``../../../model/model_metadata.json``) or absolute, whichever is shorter."""
    absolute = os.fspath(path.absolute())
    try:
        relative = os.path.relpath(absolute)
    except ValueError:  # another drive (Windows)
        return absolute
    return relative if len(relative) < len(absolute) else absolute
