"""Fixtures for queue tests: small models on the built-in oval with the compact network."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from drx.registry import Model
from drx.registry.testing import fresh_registry
from drx.services.models import create_model

MakeModel = Callable[..., Model]


@pytest.fixture(autouse=True)
def _fresh_registry(monkeypatch: pytest.MonkeyPatch) -> Any:
    """Each test gets an empty registry: SQLite in its data home, or ``$DRX_TEST_DATABASE_URL``
    (e.g. PostgreSQL; emptied first) so the queue is tested on another database too."""
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
