"""A private registry per test; with ``DRX_TEST_DATABASE_URL`` set, tests use (and empty) that database."""

from collections.abc import Iterator

import pytest

from drx.registry.testing import fresh_registry


@pytest.fixture(autouse=True)
def _fresh_registry(monkeypatch: pytest.MonkeyPatch, registry_backend: str) -> Iterator[None]:
    """Every registry test runs on SQLite and on a PostgreSQL the tests start (``registry_backend``)."""
    yield from fresh_registry(monkeypatch)
