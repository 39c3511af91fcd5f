"""Alembic, configured in code: no ``alembic.ini`` is needed in the working directory.

:func:`ensure_schema` upgrades a database to the newest revision; it is cheap
when the database is already current, and safe when several processes start
at once (SQLite serialises them with ``BEGIN IMMEDIATE``; PostgreSQL with an
advisory lock). To write a new migration from a checkout::

    python -m drx.registry.migrate revision -m "add something"

Alembic itself (about 0.3 s to import) loads only to upgrade or to write a migration: the
newest revision is read from the migration files (:func:`code_head`) and the database's from its
``alembic_version`` table, so every command on a current database starts without it.
"""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING

from sqlalchemy import Connection, Engine, inspect, text

from drx.registry.revisions import MIGRATIONS_DIR, code_head

if TYPE_CHECKING:
    from alembic.config import Config

_PG_LOCK_KEY = 0x6472_7800  # "drx" - any constant shared by every drx process


def alembic_config(connection: Connection | None = None) -> Config:
    """An Alembic config pointing at drx's migrations (optionally bound to ``connection``)."""
    from alembic.config import Config

    cfg = Config()
    cfg.set_main_option("script_location", str(MIGRATIONS_DIR))
    cfg.set_main_option("file_template", "%%(rev)s_%%(slug)s")
    if connection is not None:
        cfg.attributes["connection"] = connection
    return cfg


def head_revision() -> str | None:
    """The newest revision the code knows (:func:`code_head`; Alembic's answer when the files
    do not name one head)."""
    return code_head() or alembic_head()


def alembic_head() -> str | None:
    """The newest revision, as Alembic finds it in the migration scripts.

    :raises alembic.util.CommandError: the scripts have several heads.
    """
    from alembic.script import ScriptDirectory

    return ScriptDirectory.from_config(alembic_config()).get_current_head()


def current_revision(engine: Engine) -> str | None:
    """The revision the database is at (``None`` for an empty database): the row of Alembic's
    ``alembic_version`` table (Alembic decides when there are several)."""
    with engine.connect() as conn:
        if not inspect(conn).has_table("alembic_version"):
            return None
        rows = list(conn.execute(text("SELECT version_num FROM alembic_version")).scalars())
        if len(rows) <= 1:
            return rows[0] if rows else None
        from alembic.runtime.migration import MigrationContext

        return MigrationContext.configure(conn).get_current_revision()


def ensure_schema(engine: Engine) -> str | None:
    """Upgrade the database behind ``engine`` to the newest revision; return that revision."""
    head = head_revision()
    if current_revision(engine) == head:
        return head
    from alembic import command

    with engine.begin() as conn:
        if conn.dialect.name == "postgresql":
            conn.execute(text("SELECT pg_advisory_xact_lock(:key)"), {"key": _PG_LOCK_KEY})
        command.upgrade(alembic_config(conn), "head")
    return head


def _main(argv: list[str]) -> None:
    """``python -m drx.registry.migrate revision -m MSG`` writes a new, empty migration."""
    if len(argv) >= 3 and argv[0] == "revision" and argv[1] == "-m":
        from alembic import command

        command.revision(alembic_config(), message=argv[2])
    else:
        print("usage: python -m drx.registry.migrate revision -m MESSAGE", file=sys.stderr)
        raise SystemExit(2)


if __name__ == "__main__":
    _main(sys.argv[1:])
