"""Migrations run on first use, match the ORM tables, and set SQLite up for several processes."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext
from sqlalchemy import inspect, text

from drx.registry import Base, get_engine, session_scope
from drx.registry.migrate import current_revision, head_revision
from drx.registry.testing import external_test_url

TABLES = {
    "vehicles",
    "tracks",
    "reward_sources",
    "models",
    "jobs",
    "checkpoints",
    "episodes",
    "iteration_metrics",
    "evaluations",
    "evaluation_laps",
    "alembic_version",
}


def test_fresh_database_is_migrated_to_head(tmp_path: Path) -> None:
    engine = get_engine()
    assert current_revision(engine) == head_revision() is not None
    assert set(inspect(engine).get_table_names()) == TABLES


def test_migrations_match_the_orm_tables() -> None:
    with get_engine().connect() as conn:
        diff = compare_metadata(MigrationContext.configure(conn), Base.metadata)
    assert diff == [], f"the ORM tables and the migrations differ: {diff}"


@pytest.mark.skipif(external_test_url() is not None, reason="checks SQLite settings")
def test_sqlite_runs_in_wal_mode_with_foreign_keys_and_a_busy_timeout() -> None:
    with get_engine().connect() as conn:
        assert conn.execute(text("PRAGMA journal_mode")).scalar() == "wal"
        assert conn.execute(text("PRAGMA foreign_keys")).scalar() == 1
        assert conn.execute(text("PRAGMA busy_timeout")).scalar() >= 5000


def test_bad_database_urls_are_one_sentence_errors(tmp_path: Path) -> None:
    from drx.errors import DrxError

    junk = tmp_path / "junk.db"
    junk.write_text("this is not a database" * 100)
    for url, words in (
        ("not a url", "Could not parse"),
        ("nosuchdialect://x", "nosuchdialect"),
        (f"sqlite:///{junk}", "not a database"),
    ):
        with pytest.raises(DrxError, match=words) as info:
            get_engine(url)
        assert "DRX_DATABASE_URL" in str(info.value) and "\n" not in str(info.value)


def test_database_url_environment_variable_is_used(tmp_path: Path, monkeypatch) -> None:
    db = tmp_path / "elsewhere.db"
    monkeypatch.setenv("DRX_DATABASE_URL", f"sqlite:///{db}")
    with session_scope() as session:
        session.execute(text("SELECT 1"))
    assert db.is_file()


def test_in_memory_database_works() -> None:
    engine = get_engine("sqlite://")
    assert current_revision(engine) == head_revision()


def test_migration_is_idempotent_and_safe_for_concurrent_first_use(tmp_path: Path) -> None:
    url = f"sqlite:///{tmp_path / 'shared.db'}"
    code = "import sys; from drx.registry import get_engine; get_engine(sys.argv[1])"
    procs = [subprocess.Popen([sys.executable, "-c", code, url], stderr=subprocess.PIPE) for _ in range(3)]
    for p in procs:
        _, err = p.communicate(timeout=120)
        assert p.returncode == 0, err.decode()
    assert current_revision(get_engine(url)) == head_revision()
