"""Fixtures for queue tests: small models on the built-in oval with the compact network."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from drx.registry import Model
from drx.registry.testing import TEST_URL_ENV, fresh_registry
from drx.services.models import create_model

MakeModel = Callable[..., Model]


# The queue's own rules (claims, leases, requeues, bookkeeping) run on SQLite and again on a
# PostgreSQL the tests start; the slower tests with worker processes run on SQLite (the two-host
# test, test_two_hosts.py, runs worker processes on PostgreSQL).
ON_BOTH = {"test_queue_jobs", "test_queue_bookkeeping"}


def pytest_generate_tests(metafunc: pytest.Metafunc) -> None:
    """Run the modules in :data:`ON_BOTH` once per database."""
    if metafunc.module.__name__.rsplit(".", 1)[-1] in ON_BOTH:
        metafunc.parametrize("queue_backend", ["sqlite", "postgresql"], indirect=True)


@pytest.fixture
def queue_backend(request: pytest.FixtureRequest, monkeypatch: pytest.MonkeyPatch) -> str:
    """``postgresql``: the test's registry is the PostgreSQL server the tests start."""
    backend = str(getattr(request, "param", "sqlite"))
    if backend == "postgresql":
        monkeypatch.setenv(TEST_URL_ENV, request.getfixturevalue("postgres_server").url)
    return backend


@pytest.fixture(autouse=True)
def _fresh_registry(monkeypatch: pytest.MonkeyPatch, queue_backend: str) -> Any:
    """Each test gets an empty registry: SQLite in its data home, or ``$DRX_TEST_DATABASE_URL``
    (PostgreSQL; emptied first) so the queue is tested on another database too."""
    yield from fresh_registry(monkeypatch)


@pytest.fixture
def make_model(tmp_path: Path) -> MakeModel:
    """Create a model that trains quickly: 5 episodes per iteration, compact network, oval."""

    def make(name: str = "m", reward: str | Path = "follow_center_line", **stop: Any) -> Model:
        stop.setdefault("max_episodes", 10)
        return create_model(
            name,
            track="oval",
            reward=reward,
            network="compact",
            hyperparameters={"episodes_per_iteration": 5},
            stop_conditions=stop,
        )

    return make
