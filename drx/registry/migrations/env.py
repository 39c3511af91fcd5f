"""Alembic environment for drx's registry (configured in code by drx.registry.migrate)."""

from __future__ import annotations

from alembic import context

import drx.registry.tables  # noqa: F401  (imports every table onto Base.metadata)
from drx.registry.base import Base

config = context.config
target_metadata = Base.metadata


def _run(connection) -> None:  # type: ignore[no-untyped-def]
    context.configure(connection=connection, target_metadata=target_metadata, render_as_batch=True)
    with context.begin_transaction():
        context.run_migrations()


def run_migrations() -> None:
    """Run migrations on the connection drx passed in, or on the configured registry."""
    if context.is_offline_mode():
        from drx.config import database_url

        context.configure(url=database_url(), target_metadata=target_metadata, literal_binds=True)
        with context.begin_transaction():
            context.run_migrations()
        return
    connection = config.attributes.get("connection")
    if connection is not None:
        _run(connection)
        return
    from drx.config import database_url
    from drx.registry.engine import create_registry_engine

    engine = create_registry_engine(database_url())
    with engine.begin() as conn:
        _run(conn)
    engine.dispose()


run_migrations()
