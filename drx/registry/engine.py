"""Engines and sessions for the registry, with SQLite tuned for several processes.

:func:`get_engine` creates one engine per database URL and brings its schema
to the newest Alembic revision the first time it is used. On SQLite every
connection runs in WAL mode with a busy timeout and foreign keys on, and every
transaction starts with ``BEGIN IMMEDIATE``: a transaction that reads and then
writes never fails with "database is locked" halfway; it waits (up to the busy
timeout) for the other writer instead. Keep transactions short.
"""

from __future__ import annotations

import atexit
import os
import sqlite3
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from typing import Any

from sqlalchemy import Engine, create_engine, event
from sqlalchemy.engine import make_url
from sqlalchemy.exc import ArgumentError, DBAPIError, NoSuchModuleError
from sqlalchemy.orm import Session

from drx.config import database_url
from drx.errors import DrxError

BUSY_TIMEOUT_MS = 30_000  # [ms] how long a writer waits for another one

_engines: dict[str, Engine] = {}
_lock = threading.Lock()


def is_file_sqlite(url: str) -> bool:
    """Whether ``url`` is an SQLite database in a file (not in memory)."""
    u = make_url(url)
    return u.get_backend_name() == "sqlite" and u.database not in (None, "", ":memory:")


def _read_only_file(url: str) -> str | None:
    """The path of a file SQLite database on a read-only file system (or folder), else ``None``."""
    if not is_file_sqlite(url):
        return None
    path = os.path.abspath(str(make_url(url).database))
    folder = os.path.dirname(path)
    if os.path.isfile(path) and os.path.isdir(folder) and not os.access(folder, os.W_OK):
        return path
    return None


def install_sqlite_events(engine: Engine, wal: bool, read_only: bool = False) -> None:
    """Give every new SQLite connection of ``engine`` drx's settings: SQLAlchemy-managed transactions
    begun IMMEDIATE (plain BEGIN when ``read_only``), the busy timeout, foreign keys, and WAL
    (``wal``)."""

    @event.listens_for(engine, "connect")
    def _on_connect(dbapi_connection: Any, _record: Any) -> None:
        # Let SQLAlchemy, not the sqlite3 module, decide when transactions begin.
        dbapi_connection.isolation_level = None
        cursor = dbapi_connection.cursor()
        cursor.execute(f"PRAGMA busy_timeout = {BUSY_TIMEOUT_MS}")
        cursor.execute("PRAGMA foreign_keys = ON")
        if wal:
            _set_wal(cursor)
            cursor.execute("PRAGMA synchronous = NORMAL")
        cursor.close()

    @event.listens_for(engine, "begin")
    def _on_begin(conn: Any) -> None:
        conn.exec_driver_sql("BEGIN" if read_only else "BEGIN IMMEDIATE")


def _set_wal(cursor: Any) -> None:
    """Switch to WAL, retrying: SQLite answers "database is locked" at once, without waiting
    on the busy timeout, when another process is switching the same new file at that moment."""
    deadline = time.monotonic() + BUSY_TIMEOUT_MS / 1000
    while True:
        try:
            cursor.execute("PRAGMA journal_mode = WAL")
            return
        except sqlite3.OperationalError as exc:
            if "locked" not in str(exc) or time.monotonic() > deadline:
                raise
            time.sleep(0.05)


def create_registry_engine(url: str) -> Engine:
    """A new engine for ``url`` with drx's connection settings (no migration)."""
    u = make_url(url)
    if u.get_backend_name() == "sqlite":
        read_only = _read_only_file(url)
        if read_only is not None:
            # A read-only home (a read-only mount, a backup): open the file immutable, so SQLite
            # needs no lock or WAL index beside it; reading works, any write fails with a sentence.
            ro_url = f"sqlite:///file:{read_only}?mode=ro&immutable=1&uri=true"
            engine = create_engine(ro_url, connect_args={"timeout": BUSY_TIMEOUT_MS / 1000})
            install_sqlite_events(engine, wal=False, read_only=True)
            return engine
        engine = create_engine(url, connect_args={"timeout": BUSY_TIMEOUT_MS / 1000})
        install_sqlite_events(engine, wal=is_file_sqlite(url))
        return engine
    return create_engine(url, pool_pre_ping=True)


def get_engine(url: str | None = None) -> Engine:
    """The engine for ``url`` (default :func:`drx.config.database_url`), migrated to the newest schema.

    :param url: any SQLAlchemy URL; ``None`` reads ``$DRX_DATABASE_URL`` / ``$DRX_HOME``.
    """
    # every table mapped before a session uses one (``drx.registry``'s names load lazily)
    from drx.registry import evaluations, job_rows, metrics, model_rows, track_rows, vehicle_rows  # noqa: F401
    from drx.registry.migrate import ensure_schema

    url = url or database_url()
    with _lock:
        engine = _engines.get(url)
        if engine is None:
            try:
                engine = create_registry_engine(url)
            except (ArgumentError, NoSuchModuleError, ImportError) as exc:
                raise _open_error(url, exc) from None
            try:
                ensure_schema(engine)
            except (DBAPIError, ImportError) as exc:
                engine.dispose()
                raise _open_error(url, exc) from None
            except BaseException:
                engine.dispose()
                raise
            _engines[url] = engine
    return engine


def _open_error(url: str, exc: Exception) -> DrxError:
    """A one-sentence error for a registry that cannot be opened."""
    reason = str(getattr(exc, "orig", None) or exc).strip().splitlines()[0].rstrip(".")
    try:
        shown = make_url(url).render_as_string(hide_password=True)
    except ArgumentError:
        shown = url
    return DrxError(f"Cannot open the registry at {shown} ({reason}); check DRX_DATABASE_URL or DRX_HOME.")


@contextmanager
def session_scope(url: str | None = None) -> Iterator[Session]:
    """A session in one transaction: committed when the block ends, rolled back on any exception.

    Objects stay usable after the block (``expire_on_commit=False``).

    :param url: database URL; ``None`` for the configured registry.
    """
    session = Session(get_engine(url), expire_on_commit=False)
    try:
        yield session
        session.commit()
    except BaseException:
        session.rollback()
        raise
    finally:
        session.close()


def storage_error(exc: BaseException) -> DrxError | None:
    """One sentence for a full disk or a read-only registry/home, else ``None``.

    :param exc: a database error or an ``OSError`` from writing files.
    """
    from drx.config import data_home

    text = str(getattr(exc, "orig", None) or exc).lower()
    errno = getattr(exc, "errno", None) or getattr(getattr(exc, "orig", None), "errno", None)
    where = os.environ.get("DRX_DATABASE_URL") and "the registry database" or f"DRX_HOME ({data_home()})"
    if errno == 28 or "disk is full" in text or "no space left" in text:
        return DrxError(f"The disk holding {where} is full; free some space and run the command again.")
    if errno == 30 or "readonly database" in text or "read-only file system" in text:
        return DrxError(
            f"{where[0].upper() + where[1:]} is read-only: drx can list and show, not change anything; "
            "point DRX_HOME at a writable folder to do that."
        )
    return None


def _close_at_exit() -> None:
    """Close the engines' connections when the process ends, rather than leaving that to the
    garbage collector: SQLite folds its write-ahead log into the database when the last connection
    closes (a copy of the file, or a read-only mount of it, then sees every write). Without the
    lock: a thread stopped mid-call must not hang the exit."""
    for engine in list(_engines.values()):
        with suppress(Exception):  # exiting anyway; the log is folded in on the next open
            engine.dispose()


atexit.register(_close_at_exit)


def dispose_engines() -> None:
    """Close every cached engine and quick connection (tests call this between temporary data homes)."""
    from drx.registry import quick

    quick.forget()
    with _lock:
        for engine in _engines.values():
            engine.dispose()
        _engines.clear()
