"""Alembic, configured in code: no ``alembic.ini`` is needed in the working directory.

:func:`ensure_schema` upgrades a database to the newest revision; it is cheap
when the database is already current, and safe when several processes start
at once (SQLite serialises them with ``BEGIN IMMEDIATE``; PostgreSQL with an
advisory lock). To write a new migration from a checkout::

    python -m drx.registry.migrate revision -m "add something"
"""

from __future__ import annotations

import sys
from pathlib import Path

from alembic import command
from alembic.config import Config
from alembic.runtime.migration import MigrationContext
from alembic.script import ScriptDirectory
from sqlalchemy import Connection, Engine, text

MIGRATIONS_DIR = Path(__file__).resolve().parent / "migrations"
_PG_LOCK_KEY = 0x6472_7800  # "drx" - any constant shared by every drx process


def alembic_config(connection: Connection | None = None) -> Config:
    """An Alembic config pointing at drx's migrations (optionally bound to ``connection``)."""
    cfg = Config()
    cfg.set_main_option("script_location", str(MIGRATIONS_DIR))
    cfg.set_main_option("file_template", "%%(rev)s_%%(slug)s")
    if connection is not None:
        cfg.attributes["connection"] = connection
    return cfg


def head_revision() -> str | None:
    """The newest revision the code knows."""
    return ScriptDirectory.from_config(alembic_config()).get_current_head()


def current_revision(engine: Engine) -> str | None:
    """The revision the database is at (``None`` for an empty database)."""
    with engine.connect() as conn:
        return MigrationContext.configure(conn).get_current_revision()


def ensure_schema(engine: Engine) -> str | None:
    """Upgrade the database behind ``engine`` to the newest revision; return that revision."""
    head = head_revision()
    if current_revision(engine) == head:
        return head
    with engine.begin() as conn:
        if conn.dialect.name == "postgresql":
            conn.execute(text("SELECT pg_advisory_xact_lock(:key)"), {"key": _PG_LOCK_KEY})
        command.upgrade(alembic_config(conn), "head")
    return head


def _main(argv: list[str]) -> None:
    """``python -m drx.registry.migrate revision -m MSG`` writes a new, empty migration."""
    if len(argv) >= 3 and argv[0] == "revision" and argv[1] == "-m":
        command.revision(alembic_config(), message=argv[2])
    else:
        print("usage: python -m drx.registry.migrate revision -m MESSAGE", file=sys.stderr)
        raise SystemExit(2)


if __name__ == "__main__":
    _main(sys.argv[1:])
