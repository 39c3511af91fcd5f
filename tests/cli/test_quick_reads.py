"""The everyday listings read a current SQLite registry without SQLAlchemy (issue 40, item 2), say
exactly what the SQLAlchemy way says, and leave an outdated registry to the migrations."""

from __future__ import annotations

import sqlite3
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import pytest
from alembic import command

from drx.config import database_url
from drx.evaluate.time_trial import RaceRules
from drx.registry import Evaluation, EvaluationLap, dispose_engines, quick, session_scope
from drx.registry.engine import create_registry_engine
from drx.registry.migrate import alembic_config, current_revision, head_revision
from drx.services import models as model_service
from drx.sim.catalogue import SHIPPED_FOLDERS

from .helpers import ok, ok_json
from .test_startup import probe

LISTINGS = (
    ("model", "list"),
    ("garage", "list"),
    ("track", "list", "--source", "imported"),
    ("jobs", "list"),
    ("jobs", "list", "--status", "queued", "--model", "b"),
    ("leaderboard",),
    ("leaderboard", "--track", "oval", "--laps", "3"),
    ("info",),
)


def _evaluation(model: str, times: list[float | None], minute: int) -> None:
    """A complete three-lap evaluation of ``model`` on the oval, stored as ``drx evaluate`` stores it."""
    stored = RaceRules(laps=3).to_dict() | {"car": "default", "action_space": "10 actions", "best_lap": 7.0}
    with session_scope() as session:
        ev = Evaluation(
            model_id=model_service.get_model(model).id, track_name="oval", rules=stored, status="complete",
            laps_completed=sum(t is not None for t in times),
            created_at=datetime(2026, 3, 1, 12, tzinfo=UTC) + timedelta(minutes=minute),
        )  # fmt: skip
        ev.laps = [
            EvaluationLap(lap=i + 1, time=t, progress=100.0 if t is not None else 40.0,
                          status="lap_complete" if t is not None else "off_track")
            for i, t in enumerate(times)
        ]  # fmt: skip
        session.add(ev)


@pytest.fixture
def filled() -> None:
    """A registry with every kind of row the listings show."""
    ok("model", "create", "a", "--description", "first")
    ok("model", "create", "b", "--track", "oval", "--algo", "ppo", "--domain-randomization")
    ok("garage", "add", "fast", "--max-speed", "3")
    route = SHIPPED_FOLDERS["deepracer"] / "reInvent2019_track.npy"
    ok("track", "import", str(route), "--name", "my-track")
    ok("train", "a", "--detach")
    ok("jobs", "stop", "1")
    ok("train", "b", "--detach")
    _evaluation("a", [9.0, 9.5, None], 1)
    _evaluation("b", [8.0, 8.5, 8.2], 2)


def _slow_way(monkeypatch: pytest.MonkeyPatch) -> None:
    """Close the quick way: every read goes through SQLAlchemy."""
    monkeypatch.setattr(quick, "connection", lambda: None)


@pytest.mark.usefixtures("filled")
@pytest.mark.parametrize("argv", LISTINGS, ids=" ".join)
def test_the_quick_reads_say_what_sqlalchemy_says(
    argv: tuple[str, ...], monkeypatch: pytest.MonkeyPatch
) -> None:
    quick.forget()
    fast = ok_json(*argv)
    assert quick.connection() is not None  # the quick way was open
    _slow_way(monkeypatch)
    assert ok_json(*argv) == fast
    if argv[0] in ("model", "jobs", "leaderboard"):
        assert fast and (fast if isinstance(fast, list) else fast["rows"]), "nothing was compared"


def test_only_a_current_sqlite_registry_is_read_the_quick_way(tmp_path: Path) -> None:
    """No file yet, another revision in ``alembic_version``, several rows there, another database:
    the quick way is closed (the caller goes through SQLAlchemy and its migrations)."""
    quick.forget()
    assert quick.connection() is None  # no registry file yet
    ok("info")  # creates it
    quick.forget()
    assert quick.connection() is not None
    path = quick.sqlite_file(database_url())
    assert path is not None
    for rows in (["0001"], ["9999zz"], [head_revision(), "0001"]):
        with sqlite3.connect(path) as conn:
            conn.execute("DELETE FROM alembic_version")
            conn.executemany("INSERT INTO alembic_version VALUES (?)", [(r,) for r in rows])
        quick.forget()
        assert quick.connection() is None, rows
    assert quick.sqlite_file("postgresql://u:p@host/db") is None
    assert quick.sqlite_file("sqlite://") is None and quick.sqlite_file("sqlite:///x.db?mode=ro") is None


def test_an_outdated_registry_is_still_upgraded_by_a_listing(tmp_path: Path) -> None:
    """A registry left at an old revision: ``drx model list`` (which reads the quick way when it
    can) upgrades it as every command does, then lists."""
    dispose_engines()
    engine = create_registry_engine(database_url())
    with engine.begin() as conn:
        command.upgrade(alembic_config(conn), "0001")
    engine.dispose()
    quick.forget()
    assert quick.connection() is None
    assert ok_json("model", "list") == []
    assert current_revision(create_registry_engine(database_url())) == head_revision()
    quick.forget()
    assert quick.connection() is not None  # current now: the next listing reads at once


def test_jobs_and_the_leaderboard_are_listed_without_sqlalchemy(tmp_path: Path) -> None:
    """The fast path: on a current registry ``drx jobs list`` and ``drx leaderboard`` import neither
    SQLAlchemy nor Alembic (``model list``, ``garage list``, ``track list`` and ``info``:
    tests/cli/test_startup.py)."""
    probe(["info"], tmp_path)  # creates and migrates the registry (SQLAlchemy and Alembic run then)
    for argv in (["jobs", "list"], ["leaderboard"]):
        seen: dict[str, Any] = probe(argv, tmp_path)
        assert seen["heavy"] == [], argv
