"""A private registry per test (the data home is already private: see tests/conftest.py)."""

from collections.abc import Iterator

import pytest

from drx.registry.testing import fresh_registry


@pytest.fixture(autouse=True)
def _fresh_registry(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    yield from fresh_registry(monkeypatch)
