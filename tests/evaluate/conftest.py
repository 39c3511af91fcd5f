"""A private registry per test (the data home is already private: see tests/conftest.py)."""

from collections.abc import Iterator

import pytest

from drx.registry import dispose_engines
from drx.registry.testing import empty_database, external_test_url


@pytest.fixture(autouse=True)
def _fresh_registry(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    url = external_test_url()
    if url:
        monkeypatch.setenv("DRX_DATABASE_URL", url)
        empty_database(url)
    dispose_engines()
    yield
    dispose_engines()
