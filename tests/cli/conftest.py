"""Close the registry's cached engines after each test (each test has its own DRX_HOME)."""

from collections.abc import Iterator

import pytest

from drx.registry import dispose_engines


@pytest.fixture(autouse=True)
def _fresh_engines() -> Iterator[None]:
    dispose_engines()
    yield
    dispose_engines()
