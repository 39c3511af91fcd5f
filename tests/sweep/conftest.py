"""Sweep tests: a private registry per test (SQLite, or ``DRX_TEST_DATABASE_URL`` emptied of drx's
and Optuna's tables), and a small source model that trains in seconds."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import Any

import pytest

from drx.registry import Model
from drx.registry.testing import external_test_url, fresh_registry
from drx.services.models import create_model

MakeModel = Callable[..., Model]


def _drop_optuna_tables(url: str) -> None:
    from optuna.storages._rdb import models
    from sqlalchemy import create_engine

    engine = create_engine(url)
    try:
        models.BaseModel.metadata.drop_all(engine)
    finally:
        engine.dispose()


@pytest.fixture(autouse=True)
def _fresh_registry(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    url = external_test_url()
    if url:  # drx's own emptying leaves Optuna's tables, and their studies, behind
        _drop_optuna_tables(url)
    yield from fresh_registry(monkeypatch)


@pytest.fixture
def make_source() -> MakeModel:
    """A source model: compact network on the oval, 5 episodes per iteration, ``max_episodes`` to stop."""

    def make(name: str = "base", max_episodes: int = 10, **hp: Any) -> Model:
        return create_model(
            name,
            track="oval",
            network="compact",
            hyperparameters={"episodes_per_iteration": 5, **hp},
            stop_conditions={"max_episodes": max_episodes},
        )

    return make
