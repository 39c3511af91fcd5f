"""The registry read at once: the everyday listings' reads on SQLite, without SQLAlchemy.

``drx model list``, ``garage list``, ``track list``, ``jobs list``, ``leaderboard`` and ``info``
would spend most of their start importing SQLAlchemy and mapping the tables. On the default
registry (an SQLite file) they read through the standard library's ``sqlite3`` instead:

- only a *current* database is read so: its ``alembic_version`` must be the one head the code's
  migration files name (:func:`drx.registry.revisions.code_head`, read without Alembic). A missing
  file, an older or newer revision, several heads, another database (``DRX_DATABASE_URL``), a
  read-only home or any SQLite error give ``None``, and the caller takes SQLAlchemy's way, which
  creates, migrates or refuses the database exactly as every other command does;
- the rows come back as :class:`Record` objects with the table's column names as attributes;
  JSON columns are decoded, timestamps read back as aware UTC and flags as ``bool``, as the
  registry's column types do (:mod:`drx.registry.base`), so one rendering serves both ways.

Raw SQL lives in the registry package only: the listing services name their queries here.
"""

from __future__ import annotations

import atexit
import json
import os
import sqlite3
import threading
from collections.abc import Iterable, Sequence
from datetime import UTC, datetime
from pathlib import Path
from types import SimpleNamespace
from typing import TYPE_CHECKING, Any
from urllib.parse import quote

from drx.config import database_url
from drx.registry.revisions import code_head

if TYPE_CHECKING:  # the settings (and the car) load only for the models' rows
    from drx.registry.model_settings import ModelRecord

BUSY_TIMEOUT_S = 30.0  # as long as the registry's engine waits for a writer
SQLITE_PREFIX = "sqlite:///"

_connections: dict[str, sqlite3.Connection | None] = {}  # by database URL: opened (or refused) once
_lock = threading.Lock()  # one statement at a time on a connection (drx watch reads from threads)


class Record(SimpleNamespace):
    """A row: its columns as attributes."""


MODEL_JSON = ("vehicle_spec", "hyperparameters", "stop_conditions", "race", "episode_options", "recipe")
MODEL_TIMES = ("created_at", "updated_at")
MODEL_FLAGS = ("domain_randomization", "car_randomization")
JOB_JSON = ("options", "attempt_log")
JOB_TIMES = ("created_at", "started_at", "finished_at", "heartbeat_at")
JOB_FLAGS = ("stop_requested",)


def sqlite_file(url: str) -> Path | None:
    """The file of a plain SQLite URL (``sqlite:///path``, no query), else ``None``."""
    if not url.startswith(SQLITE_PREFIX) or "?" in url:
        return None
    path = url[len(SQLITE_PREFIX) :]
    return None if path in ("", ":memory:") else Path(path)


def _open(url: str) -> sqlite3.Connection | None:
    """A connection to the registry at ``url`` when it is a current SQLite file, else ``None``."""
    path = sqlite_file(url)
    head = code_head()
    if path is None or head is None or not path.is_file() or not os.access(path.parent, os.W_OK):
        return None
    try:
        connection = sqlite3.connect(
            f"file:{quote(str(path.resolve()))}?mode=rw", uri=True, timeout=BUSY_TIMEOUT_S,
            isolation_level=None, check_same_thread=False,
        )  # fmt: skip
    except sqlite3.Error:
        return None
    try:
        revisions = [row[0] for row in connection.execute("SELECT version_num FROM alembic_version")]
    except sqlite3.Error:
        revisions = []
    if revisions != [head]:
        connection.close()
        return None
    return connection


def connection() -> sqlite3.Connection | None:
    """The process's quick connection (opened on first use), or ``None``: use SQLAlchemy."""
    url = database_url()
    with _lock:
        if url not in _connections:
            _connections[url] = _open(url)
        return _connections[url]


def forget() -> None:
    """Close the quick connections; the next read opens (and checks) the database again
    (:func:`drx.registry.engine.dispose_engines` calls this)."""
    with _lock:
        for conn in _connections.values():
            if conn is not None:
                conn.close()
        _connections.clear()


atexit.register(forget)


def _time(value: Any) -> datetime | None:
    """A stored timestamp (naive UTC text) as an aware UTC datetime."""
    if value is None:
        return None
    moment = datetime.fromisoformat(value) if isinstance(value, str) else value
    return moment.replace(tzinfo=UTC) if moment.tzinfo is None else moment.astimezone(UTC)


def read(
    sql: str,
    params: Sequence[Any] = (),
    *,
    json_columns: Iterable[str] = (),
    times: Iterable[str] = (),
    flags: Iterable[str] = (),
    record: type[SimpleNamespace] = Record,
) -> list[Any] | None:
    """The rows of ``sql`` as ``record`` objects, or ``None`` when the quick way is closed (see the
    module's docstring): then read through SQLAlchemy.

    :param json_columns: columns holding JSON (decoded; SQL ``NULL`` and JSON ``null`` give ``None``).
    :param times: timestamp columns (aware UTC ``datetime``).
    :param flags: boolean columns (``bool``).
    """
    conn = connection()
    if conn is None:
        return None
    try:
        with _lock:
            cursor = conn.execute(sql, tuple(params))
            names = [d[0] for d in cursor.description]
            rows = cursor.fetchall()
    except sqlite3.Error:
        return None
    decoders: dict[str, Any] = {}
    decoders.update({c: lambda v: None if v is None else json.loads(v) for c in json_columns})
    decoders.update({c: _time for c in times})
    decoders.update({c: lambda v: None if v is None else bool(v) for c in flags})
    out = []
    for row in rows:
        values = dict(zip(names, row, strict=True))
        for column, decode in decoders.items():
            if column in values:
                values[column] = decode(values[column])
        out.append(record(**values))
    return out


def models() -> list[ModelRecord] | None:
    """Every model, oldest first (as :func:`drx.services.models.list_models`), with the settings
    methods of :class:`drx.registry.model_rows.Model`."""
    from drx.registry.model_settings import ModelRecord

    return read(
        "SELECT * FROM models ORDER BY created_at, id",
        json_columns=MODEL_JSON, times=MODEL_TIMES, flags=MODEL_FLAGS, record=ModelRecord,
    )  # fmt: skip


def vehicles() -> list[Record] | None:
    """The garage's stored cars by name (``name``, ``spec``, ``source``, ``created_at``)."""
    return read(
        "SELECT name, spec, source, created_at FROM vehicles ORDER BY name",
        json_columns=("spec",), times=("created_at",),
    )  # fmt: skip


def imported_tracks() -> list[Record] | None:
    """The imported tracks' rows by name (every column of ``tracks``)."""
    return read(
        "SELECT * FROM tracks ORDER BY name",
        json_columns=("notes",), times=("created_at",), flags=("closed",),
    )  # fmt: skip


def jobs(status: str | None, model_name: str | None, limit: int) -> list[tuple[Record, str]] | None:
    """Recent jobs, newest first, with their model's name (as :func:`drx.queue.lifecycle.list_jobs`)."""
    where, params = [], []
    if status:
        where.append("jobs.status = ?")
        params.append(status)
    if model_name:
        where.append("models.name = ?")
        params.append(model_name)
    sql = (
        "SELECT jobs.*, models.name AS drx_model_name FROM jobs JOIN models ON models.id = jobs.model_id"
        + (" WHERE " + " AND ".join(where) if where else "")
        + " ORDER BY jobs.id DESC LIMIT ?"
    )
    rows = read(sql, [*params, limit], json_columns=JOB_JSON, times=JOB_TIMES, flags=JOB_FLAGS)
    if rows is None:
        return None
    return [(row, vars(row).pop("drx_model_name")) for row in rows]


COUNTED_TABLES = {
    "cars": "vehicles",
    "imported_tracks": "tracks",
    "reward_sources": "reward_sources",
    "models": "models",
    "jobs": "jobs",
    "checkpoints": "checkpoints",
    "episodes": "episodes",
    "evaluations": "evaluations",
}


def counts() -> dict[str, int] | None:
    """How many rows each table ``drx info`` counts holds, and the active (queued or running) jobs."""
    parts = [f"(SELECT count(*) FROM {table}) AS {name}" for name, table in COUNTED_TABLES.items()]
    parts.append("(SELECT count(*) FROM jobs WHERE status IN ('queued', 'running')) AS active_jobs")
    rows = read("SELECT " + ", ".join(parts))
    return None if rows is None else {k: int(v or 0) for k, v in vars(rows[0]).items()}


def revision() -> str | None:
    """The database's revision when the quick way is open (it is then the code's head), else ``None``."""
    return code_head() if connection() is not None else None


def complete_evaluations() -> list[tuple[Record, str]] | None:
    """Every complete evaluation, oldest first (by time, then id), with its model's name; each has
    ``laps``, its laps in order (as :class:`drx.registry.evaluations.Evaluation` does)."""
    rows = read(
        "SELECT evaluations.*, models.name AS drx_model_name FROM evaluations"
        " JOIN models ON models.id = evaluations.model_id WHERE evaluations.status = 'complete'"
        " ORDER BY evaluations.created_at, evaluations.id",
        json_columns=("rules",), times=("created_at", "finished_at"),
    )  # fmt: skip
    if rows is None:
        return None
    laps = read(
        "SELECT evaluation_laps.* FROM evaluation_laps JOIN evaluations"
        " ON evaluations.id = evaluation_laps.evaluation_id WHERE evaluations.status = 'complete'"
        " ORDER BY evaluation_laps.evaluation_id, evaluation_laps.lap"
    )
    if laps is None:
        return None
    by_evaluation: dict[int, list[Record]] = {}
    for lap in laps:
        by_evaluation.setdefault(lap.evaluation_id, []).append(lap)
    out = []
    for row in rows:
        name = vars(row).pop("drx_model_name")
        row.laps = by_evaluation.get(row.id, [])
        out.append((row, name))
    return out


def raced_track_names() -> set[str] | None:
    """The tracks any evaluation raced on."""
    rows = read("SELECT DISTINCT track_name FROM evaluations")
    return None if rows is None else {row.track_name for row in rows}
