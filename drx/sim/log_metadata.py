"""Which DeepRacer simulator recorded a log, read from the log's own metadata (``drx sim replay``).

drx's car is fitted per DeepRacer simulator version (deepracer-simapp; :mod:`drx.sim.car_calibration`
``SIMULATORS``). A log names the version that recorded it in one of three places, read in this order:

1. **the robomaker log itself**: at start-up deepracer-simapp logs the model's metadata as it parsed it
   (``bundle/markov/boto/s3/files/model_metadata.py``, ``parse_model_metadata``), e.g. ``Sensor list
   ['FRONT_FACING_CAMERA'], network DEEP_CONVOLUTIONAL_NETWORK_SHALLOW, simapp_version 5.0,
   training_algorithm clipped_ppo, ...``. The line comes before the first ``SIM_TRACE_LOG`` step
   (line 20-60 of the shared logs, again near line 150 in deepracer-for-cloud's); only the first
   :data:`HEADER_BYTES` of a log are read, and reading stops at the first match.
2. **deepracer-log-guru's** ``<log>.meta.json`` beside the log: ``environment.simulation_version``
   (``"5.0"``), which log-guru takes from that same line.
3. **the console's** ``model_metadata.json`` in its log layout (``sample-console-logs/model/
   model_metadata.json`` beside ``sample-console-logs/sim-trace/training/training-simtrace/*.csv``):
   ``"version": "4.0"``, the simapp version the model was made for. It is looked for, as
   ``model_metadata.json`` or ``model/model_metadata.json``, in the log's folder and the folders
   above it, :data:`MODEL_METADATA_LEVELS` folders in all (the console's evaluation traces sit five
   folders below it).

All three carry the model's ``model_metadata.json`` ``version``: simapp prints ``simapp_version`` from
it. A version drx has no car for (``3.0``, ``6.0``) gets the nearest version it has, and says so.
"""

from __future__ import annotations

import json
import os
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from drx.errors import DrxError
from drx.sim.car_calibration import DEFAULT_SIMULATOR, SIMULATORS

HEADER_BYTES = 1 << 20  # a robomaker log's start-up lines: the first MiB at most
MODEL_METADATA_LEVELS = 5  # the log's folder and the four above it
_CHUNK = 1 << 16
_SIMAPP_LINE = re.compile(rb"simapp_version[\s:=]+['\"]?(\d+(?:\.\d+)*)")
_VERSION = re.compile(r"v?(\d+)(?:\.\d+)*")

Kind = Literal["robomaker", "meta.json", "model_metadata"]
ChosenBy = Literal["user", "logs", "default"]


@dataclass(frozen=True)
class LogSimulator:
    """What one log says of the DeepRacer simulator that recorded it (:func:`simulator_of_log`).

    :param log: the log.
    :param version: drx's car for it, a key of ``SIMULATORS`` (the nearest one for a version drx has no
        car for); ``None`` when the log says nothing.
    :param logged: the version as written, e.g. ``"5.0"``.
    :param kind: where it was found: ``robomaker`` (the log's ``simapp_version`` line), ``meta.json``
        (log-guru's ``environment.simulation_version``), ``model_metadata`` (the console's ``version``).
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
    """The simulator versions drx has a car for, oldest first (``["4", "5"]``)."""
    return sorted(SIMULATORS, key=int)


def check_simulator(value: str) -> str:
    """The simulator version a user named (``5``, ``5.0``, ``v5``), as a key of ``SIMULATORS``.

    :raises DrxError: for a version drx has no car for, or not a version at all.
    """
    major = _major(value)
    if major is None or str(major) not in SIMULATORS:
        known = " or ".join(known_simulators())
        raise DrxError(f"--simulator {value} is not a DeepRacer simulator version drx has a car for; use "
                       f"{known}.")  # fmt: skip
    return str(major)


def car_for_version(logged: str) -> str | None:
    """drx's car for a logged simulator version: ``"5.0"`` -> ``"5"``; a version drx has no car for
    gets the nearest one (``"3.0"`` -> ``"4"``, ``"6.0"`` -> ``"5"``, the newer on a tie); ``None`` when
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


# --- reading one log ---------------------------------------------------------------------------


def _simulator_of_log(log: Path, cache: dict[Path, tuple[Path, Any] | None]) -> LogSimulator:
    if not log.is_file():
        return LogSimulator(log, None, reason=f"{_shown(log)} is not a file")
    logged = _simapp_line(log)
    if logged is not None:
        return _found(log, logged, "robomaker", log, f"simapp_version {logged} in the robomaker log")
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
    try:
        with log.open("rb") as f:
            buffer = f.read(min(_CHUNK, HEADER_BYTES))
            if buffer.lstrip(b"\xef\xbb\xbf \t\r\n")[:8].lower() == b"episode,":
                return None
            read = len(buffer)
            while True:
                match = _SIMAPP_LINE.search(buffer)
                if match and match.end() < len(buffer):  # not cut at the chunk's end ("5" of "5.0")
                    return match.group(1).decode("ascii")
                more = f.read(min(_CHUNK, HEADER_BYTES - read)) if read < HEADER_BYTES else b""
                if not more:
                    return match.group(1).decode("ascii") if match else None
                read += len(more)
                buffer = buffer[-200:] + more  # a line split across two chunks is still found
    except OSError:
        return None


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
        phrases.append(f"drx has no car for simulator {logged}; the nearest it has is {version}")
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
