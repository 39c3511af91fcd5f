"""Test support: a private, empty registry for every test.

Tests run against SQLite in their temporary ``DRX_HOME`` by default. Set
``DRX_TEST_DATABASE_URL`` to run them against another database (e.g. a
throw-away PostgreSQL); it is emptied before every test, so never point it at
a registry you care about::

    DRX_TEST_DATABASE_URL=postgresql+psycopg://drx@/drx_test?host=/tmp pytest tests/registry
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from typing import Any

from sqlalchemy import MetaData, select

from drx.config import data_home
from drx.registry.engine import create_registry_engine, dispose_engines, session_scope
from drx.registry.tables import Base  # every table on Base.metadata

TEST_URL_ENV = "DRX_TEST_DATABASE_URL"


def external_test_url() -> str | None:
    """The database tests should use instead of SQLite, if any (``$DRX_TEST_DATABASE_URL``)."""
    return os.environ.get(TEST_URL_ENV) or None


def empty_database(url: str) -> None:
    """Drop every drx table and Alembic's version table from ``url``."""
    dispose_engines()
    engine = create_registry_engine(url)
    try:
        Base.metadata.drop_all(engine)
        leftovers = MetaData()
        leftovers.reflect(engine, only=lambda name, _meta: name == "alembic_version")
        leftovers.drop_all(engine)
    finally:
        engine.dispose()


def fresh_registry(monkeypatch: Any) -> Iterator[None]:
    """The body of an autouse pytest fixture giving each test an empty registry: SQLite in its data
    home, or ``$DRX_TEST_DATABASE_URL`` (emptied first); ``yield from fresh_registry(monkeypatch)``.

    :param monkeypatch: pytest's ``monkeypatch`` fixture (sets ``DRX_DATABASE_URL`` for the test).
    """
    url = external_test_url()
    if url:
        monkeypatch.setenv("DRX_DATABASE_URL", url)
        empty_database(url)
    dispose_engines()
    yield
    dispose_engines()


def snapshot() -> dict[str, Any]:
    """Every registry row and every file under the data home (but the SQLite registry's own files):
    compare one taken before and one after a failed command to check it wrote nothing."""
    with session_scope() as session:
        rows = {
            table.name: [tuple(r) for r in session.execute(select(table)).all()]
            for table in Base.metadata.sorted_tables
        }
    home = data_home()
    files = sorted(
        str(p.relative_to(home)) for p in home.rglob("*") if p.is_file() and "drx.db" not in p.name
    )
    return {"rows": rows, "files": files}
