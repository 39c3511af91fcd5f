"""Migrations run on first use, match the ORM tables, and set SQLite up for several processes."""

from __future__ import annotations

import json
import subprocess
import sys
from datetime import UTC, datetime
from pathlib import Path

import pytest
from alembic import command
from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext
from sqlalchemy import Connection, column, inspect, select, table, text

from drx.registry import Base, get_engine, session_scope
from drx.registry.engine import create_registry_engine
from drx.registry.migrate import alembic_config, alembic_head, code_head, current_revision, head_revision
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
    "races",
    "race_entries",
    "alembic_version",
}


def test_fresh_database_is_migrated_to_head(tmp_path: Path) -> None:
    engine = get_engine()
    assert current_revision(engine) == head_revision() is not None
    assert set(inspect(engine).get_table_names()) == TABLES


def test_the_head_read_from_the_files_is_alembics() -> None:
    """code_head (no Alembic import) names the revision Alembic finds, and so does the database."""
    assert code_head() == alembic_head() == head_revision() is not None
    with get_engine().connect() as conn:
        assert current_revision(get_engine()) == MigrationContext.configure(conn).get_current_revision()


def test_an_outdated_database_is_still_upgraded(tmp_path: Path) -> None:
    """The fast check sees an older revision and lets Alembic upgrade (the first migration's tables
    are there, the newest one's column comes)."""
    url = f"sqlite:///{tmp_path / 'old.db'}"
    engine = create_registry_engine(url)
    with engine.begin() as conn:
        command.upgrade(alembic_config(conn), "0001")
    assert current_revision(engine) == "0001"
    assert current_revision(get_engine(url)) == head_revision()


def test_migrations_match_the_orm_tables() -> None:
    with get_engine().connect() as conn:
        diff = compare_metadata(MigrationContext.configure(conn), Base.metadata)
    assert diff == [], f"the ORM tables and the migrations differ: {diff}"


def test_sqlite_runs_in_wal_mode_with_foreign_keys_and_a_busy_timeout() -> None:
    if external_test_url() is not None:  # the PostgreSQL run (registry_backend)
        pytest.skip("checks SQLite settings")
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


def test_models_from_before_race_types_become_time_trials(tmp_path: Path) -> None:
    """Migration 0002 on a registry holding a model: the model gets the time-trial race."""
    url = external_test_url() or f"sqlite:///{tmp_path / 'old.db'}"
    engine = create_registry_engine(url)
    with engine.begin() as conn:
        config = alembic_config(conn)
        command.downgrade(config, "base")
        command.upgrade(config, "0001")
        # Tables as revision 0001 had them (the ORM classes already know revision 0002's columns).
        now = datetime.now(UTC)
        rewards = table("reward_sources", *(column(c) for c in ("sha256", "filename", "code", "created_at")))
        conn.execute(rewards.insert().values(sha256="x", filename="r.py", code="", created_at=now))
        columns = ("name", "vehicle_name", "vehicle_spec", "track_name", "reward_sha256", "reward_filename",
                   "algorithm", "hyperparameters", "stop_conditions", "status", "created_at",
                   "updated_at")  # fmt: skip
        values = ("old", "default", "{}", "oval", "x", "r.py", "ppo", "{}", "{}", "draft", now, now)
        models = table("models", *(column(c) for c in columns))
        conn.execute(models.insert().values(dict(zip(columns, values, strict=True))))
        command.upgrade(config, "head")
        race = conn.execute(select(table("models", column("race"))).limit(1)).scalar_one()
    race = json.loads(race) if isinstance(race, str) else race
    assert race["race_type"] == "time-trial" and race["objects"] == 0
    engine.dispose()


def test_models_from_before_domain_randomization_train_without_it(tmp_path: Path) -> None:
    """Migration 0003 on a registry holding a model: the model's switch is off."""
    url = external_test_url() or f"sqlite:///{tmp_path / 'old.db'}"
    engine = create_registry_engine(url)
    with engine.begin() as conn:
        config = alembic_config(conn)
        command.downgrade(config, "base")
        command.upgrade(config, "0002")
        now = datetime.now(UTC)
        rewards = table("reward_sources", *(column(c) for c in ("sha256", "filename", "code", "created_at")))
        conn.execute(rewards.insert().values(sha256="x", filename="r.py", code="", created_at=now))
        columns = ("name", "vehicle_name", "vehicle_spec", "track_name", "reward_sha256", "reward_filename",
                   "algorithm", "hyperparameters", "stop_conditions", "race", "status", "created_at",
                   "updated_at")  # fmt: skip
        values = ("old", "default", "{}", "oval", "x", "r.py", "ppo", "{}", "{}", "{}", "draft", now, now)
        models = table("models", *(column(c) for c in columns))
        conn.execute(models.insert().values(dict(zip(columns, values, strict=True))))
        command.upgrade(config, "head")
        flag = conn.execute(select(table("models", column("domain_randomization"))).limit(1)).scalar_one()
    assert not flag
    engine.dispose()


def test_models_from_before_rollout_workers_get_the_automatic_count(tmp_path: Path) -> None:
    """Migration 0005t on a registry holding a model: its rollout-worker count is NULL (automatic)."""
    url = external_test_url() or f"sqlite:///{tmp_path / 'old.db'}"
    engine = create_registry_engine(url)
    with engine.begin() as conn:
        config = alembic_config(conn)
        command.downgrade(config, "base")
        command.upgrade(config, "0004")
        now = datetime.now(UTC)
        rewards = table("reward_sources", *(column(c) for c in ("sha256", "filename", "code", "created_at")))
        conn.execute(rewards.insert().values(sha256="x", filename="r.py", code="", created_at=now))
        columns = ("name", "vehicle_name", "vehicle_spec", "track_name", "reward_sha256", "reward_filename",
                   "algorithm", "hyperparameters", "stop_conditions", "race", "domain_randomization",
                   "status", "created_at", "updated_at")  # fmt: skip
        values = (
            "old",
            "default",
            "{}",
            "oval",
            "x",
            "r.py",
            "ppo",
            "{}",
            "{}",
            "{}",
            False,
            "draft",
            now,
            now,
        )
        models = table("models", *(column(c) for c in columns))
        conn.execute(models.insert().values(dict(zip(columns, values, strict=True))))
        command.upgrade(config, "head")
        count = conn.execute(select(table("models", column("rollout_workers"))).limit(1)).scalar_one()
    assert count is None
    engine.dispose()


def test_models_and_episodes_from_before_episode_options_train_as_they_did(tmp_path: Path) -> None:
    """Migration 0007o on a registry holding a model and an episode: the model's options are NULL,
    read as its one track, its route's own way, with DeepRacer's default starts; the episode names
    no track (its model's)."""
    from drx.registry import Model
    from drx.settings.episodes import EpisodeSettings, TrainingTrack

    url = external_test_url() or f"sqlite:///{tmp_path / 'old.db'}"
    engine = create_registry_engine(url)
    with engine.begin() as conn:
        config = alembic_config(conn)
        command.downgrade(config, "base")
        command.upgrade(config, "0006h")
        now = _insert_old_model(conn)
        columns = ("model_id", "iteration", "episode", "phase", "reward", "progress", "steps", "status",
                   "start_fraction", "created_at")  # fmt: skip
        values = (1, 0, 0, "training", 1.0, 10.0, 5, "off_track", 0.0, now)
        episodes = table("episodes", *(column(c) for c in columns))
        conn.execute(episodes.insert().values(dict(zip(columns, values, strict=True))))
        command.upgrade(config, "head")
        options = conn.execute(select(table("models", column("episode_options")))).scalar_one()
        track = conn.execute(select(table("episodes", column("track_name")))).scalar_one()
        assert (options, track) == (None, None)
        command.downgrade(config, "0006h")  # and back: the columns go
        assert "episode_options" not in {c["name"] for c in inspect(conn).get_columns("models")}
        assert "track_name" not in {c["name"] for c in inspect(conn).get_columns("episodes")}
    engine.dispose()
    old = Model(name="old", track_name="oval", episode_options=None)
    assert old.episode_settings() == EpisodeSettings((TrainingTrack("oval"),))


def test_models_and_jobs_from_before_devices_train_on_auto(tmp_path: Path) -> None:
    """Migration 0008d on a registry holding a model and its job: the model's device is NULL (auto:
    the CPU where there is no GPU, where they trained), the job records none; downgrading drops both."""
    url = external_test_url() or f"sqlite:///{tmp_path / 'old.db'}"
    engine = create_registry_engine(url)
    with engine.begin() as conn:
        config = alembic_config(conn)
        command.downgrade(config, "base")
        command.upgrade(config, "0007o")
        now = _insert_old_model(conn)
        columns = ("model_id", "kind", "status", "options", "created_at", "lease_seconds", "attempts",
                   "max_attempts", "stop_requested")  # fmt: skip
        values = (1, "train", "succeeded", "{}", now, 60, 1, 3, False)
        jobs = table("jobs", *(column(c) for c in columns))
        conn.execute(jobs.insert().values(dict(zip(columns, values, strict=True))))
        command.upgrade(config, "head")
        assert conn.execute(select(table("models", column("device")))).scalar_one() is None
        assert conn.execute(select(table("jobs", column("device")))).scalar_one() is None
        command.downgrade(config, "0007o")
        assert "device" not in {c["name"] for c in inspect(conn).get_columns("models")}
        assert "device" not in {c["name"] for c in inspect(conn).get_columns("jobs")}
    engine.dispose()


def test_models_from_before_simulator_6_keep_version_5s_car(tmp_path: Path) -> None:
    """Migration 0009s on a registry holding a model: it keeps simulator 5's car (the one it trained
    on) without car randomization; downgrading drops both columns."""
    url = external_test_url() or f"sqlite:///{tmp_path / 'old.db'}"
    engine = create_registry_engine(url)
    with engine.begin() as conn:
        config = alembic_config(conn)
        command.downgrade(config, "base")
        command.upgrade(config, "0008d")
        _insert_old_model(conn)
        command.upgrade(config, "head")
        row = conn.execute(select(table("models", column("simulator"), column("car_randomization")))).one()
        assert (row.simulator, bool(row.car_randomization)) == ("5", False)
        command.downgrade(config, "0008d")
        names = {c["name"] for c in inspect(conn).get_columns("models")}
        assert not names & {"simulator", "car_randomization"}
    engine.dispose()


def test_head_to_head_races_are_new_tables_beside_the_models(tmp_path: Path) -> None:
    """Migration 0010h on a registry holding a model: the race tables come empty, a race of the
    model can be stored, and downgrading drops both tables and leaves the model."""
    url = external_test_url() or f"sqlite:///{tmp_path / 'old.db'}"
    engine = create_registry_engine(url)
    with engine.begin() as conn:
        config = alembic_config(conn)
        command.downgrade(config, "base")
        command.upgrade(config, "0008d")
        now = _insert_old_model(conn)
        command.upgrade(config, "0010h")
        assert {"races", "race_entries"} <= set(inspect(conn).get_table_names())
        races = table("races", *(column(c) for c in ("id", "track_name", "rules", "ended", "race_time",
                                                      "seed", "created_at")))  # fmt: skip
        conn.execute(races.insert().values(id=1, track_name="oval", rules="{}", ended="time_cap",
                                           race_time=1.0, seed=0, created_at=now))  # fmt: skip
        columns = ("race_id", "model_id", "start_index", "place", "status", "laps", "lap_times", "progress",
                   "collisions", "crashes", "off_track_count", "penalty_seconds")  # fmt: skip
        entries = table("race_entries", *(column(c) for c in columns))
        values = (1, 1, 0, 1, "racing", 0, "[]", 5.0, 0, 0, 0, 0.0)
        conn.execute(entries.insert().values(dict(zip(columns, values, strict=True))))
        command.downgrade(config, "0008d")
        assert not {"races", "race_entries"} & set(inspect(conn).get_table_names())
        assert conn.execute(select(table("models", column("name")))).scalar_one() == "old"
    engine.dispose()

def _insert_old_model(conn: Connection) -> datetime:
    """A reward source and model ``old`` (id 1) as the revisions 0006h-0007o stored them; the time used."""
    now = datetime.now(UTC)
    rewards = table("reward_sources", *(column(c) for c in ("sha256", "filename", "code", "created_at")))
    conn.execute(rewards.insert().values(sha256="x", filename="r.py", code="", created_at=now))
    columns = ("id", "name", "vehicle_name", "vehicle_spec", "track_name", "reward_sha256",
               "reward_filename", "algorithm", "hyperparameters", "stop_conditions", "race",
               "domain_randomization", "status", "created_at", "updated_at")  # fmt: skip
    values = (1, "old", "default", "{}", "oval", "x", "r.py", "ppo", "{}", "{}", "{}", False, "ready",
              now, now)  # fmt: skip
    models = table("models", *(column(c) for c in columns))
    conn.execute(models.insert().values(dict(zip(columns, values, strict=True))))
    return now
