"""Engines and sessions for the registry, with SQLite tuned for several processes.

:func:`get_engine` creates one engine per database URL and brings its schema
to the newest Alembic revision the first time it is used. On SQLite every
connection runs in WAL mode with a busy timeout and foreign keys on, and every
transaction starts with ``BEGIN IMMEDIATE``: a transaction that reads and then
writes never fails with "database is locked" halfway; it waits (up to the busy
timeout) for the other writer instead. Keep transactions short.
"""

from __future__ import annotations

import sqlite3
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
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


def _is_file_sqlite(url: str) -> bool:
    u = make_url(url)
    return u.get_backend_name() == "sqlite" and u.database not in (None, "", ":memory:")


def _install_sqlite_events(engine: Engine, wal: bool) -> None:
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
        conn.exec_driver_sql("BEGIN IMMEDIATE")


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
        engine = create_engine(url, connect_args={"timeout": BUSY_TIMEOUT_MS / 1000})
        _install_sqlite_events(engine, wal=_is_file_sqlite(url))
        return engine
    return create_engine(url, pool_pre_ping=True)


def get_engine(url: str | None = None) -> Engine:
    """The engine for ``url`` (default :func:`drx.config.database_url`), migrated to the newest schema.

    :param url: any SQLAlchemy URL; ``None`` reads ``$DRX_DATABASE_URL`` / ``$DRX_HOME``.
    """
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


def dispose_engines() -> None:
    """Close every cached engine (tests call this between temporary data homes)."""
    with _lock:
        for engine in _engines.values():
            engine.dispose()
        _engines.clear()
