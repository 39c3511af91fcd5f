"""Fixtures for the watch tests: a private registry, and a simulated job (a car driving, iterations)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from drx.registry.testing import fresh_registry
from tests.watch.simulated import SimulatedJob


@pytest.fixture(autouse=True)
def _fresh_registry(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    yield from fresh_registry(monkeypatch)


@pytest.fixture
def job() -> Iterator[SimulatedJob]:
    """A running training job of model ``wm`` (oval) whose car drives while the test runs."""
    sim = SimulatedJob("wm")
    try:
        yield sim
    finally:
        sim.stop()
