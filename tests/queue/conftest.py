"""Fixtures for queue tests: small models on the built-in oval with the compact network."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from drx.registry import Model, dispose_engines
from drx.services.models import create_model

MakeModel = Callable[..., Model]


@pytest.fixture(autouse=True)
def _fresh_engines() -> Any:
    """Each test's data home gets its own engine (and short job leases)."""
    dispose_engines()
    yield
    dispose_engines()


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
