"""Optuna's storage on the registry's own database (``DRX_DATABASE_URL``: SQLite or PostgreSQL).

Optuna's :class:`~optuna.storages.RDBStorage` keeps its tables (``studies``, ``trials``,
``trial_params``...; none of drx's names) beside drx's, so every host that shares the registry
shares the sweeps too, with no second server. Two details of sharing one database:

- both use Alembic's default ``alembic_version`` table, which holds drx's revision. drx migrates
  the database first (:func:`drx.registry.engine.get_engine`), so Optuna finds the table filled and
  leaves it alone; its own version check would then compare drx's revision with Optuna's, so it is
  skipped and :func:`_check_optuna_schema` checks Optuna's ``version_info`` row instead;
- on SQLite, Optuna's connections get drx's settings (WAL, a 30 s busy timeout, ``BEGIN IMMEDIATE``),
  so workers writing at once wait for each other instead of failing with "database is locked".
"""

from __future__ import annotations

import logging
from typing import Any

from sqlalchemy.engine import make_url

from drx.config import database_url
from drx.errors import DrxError
from drx.registry.engine import BUSY_TIMEOUT_MS, get_engine, install_sqlite_events, is_file_sqlite


def open_storage(url: str | None = None) -> Any:
    """Optuna's ``RDBStorage`` on the registry (migrated first), quiet unless something goes wrong.

    :param url: the registry's URL; ``None`` for :func:`drx.config.database_url`.
    :raises DrxError: the registry cannot be opened, or holds sweeps of another Optuna schema.
    """
    import optuna
    from sqlalchemy.pool import NullPool

    optuna.logging.set_verbosity(logging.WARNING)
    url = url or database_url()
    get_engine(url)  # drx's schema and alembic_version first (see the module's docstring)
    sqlite = make_url(url).get_backend_name() == "sqlite"
    kwargs: dict[str, Any] = (
        {"connect_args": {"timeout": BUSY_TIMEOUT_MS / 1000}, "poolclass": NullPool}
        if sqlite
        else {"pool_pre_ping": True}
    )
    storage = optuna.storages.RDBStorage(url, engine_kwargs=kwargs, skip_compatibility_check=True)
    if sqlite:
        install_sqlite_events(storage.engine, wal=is_file_sqlite(url))
        storage.engine.dispose()  # connections opened so far lack the settings; new ones get them
    _check_optuna_schema(storage)
    return storage


def _check_optuna_schema(storage: Any) -> None:
    """Refuse a database whose Optuna tables another Optuna version laid out differently."""
    from optuna.storages._rdb import models

    with storage.engine.connect() as conn:
        row = conn.execute(models.VersionInfoModel.__table__.select()).first()
    if row is not None and row.schema_version != models.SCHEMA_VERSION:
        raise DrxError(
            f"The registry's sweeps were written by Optuna {row.library_version} (schema "
            f"{row.schema_version}), this drx uses schema {models.SCHEMA_VERSION}; install the Optuna "
            "version pinned in constraints.txt on every host."
        )
