"""Fixtures: a private registry per test, and one real short training run shared by the analysis tests."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from drx.registry import dispose_engines
from drx.registry.testing import fresh_registry

from ._run import train_tiny

TRAINED_MODEL = "base"


@pytest.fixture(autouse=True)
def _fresh_registry(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    yield from fresh_registry(monkeypatch)


@pytest.fixture(scope="session")
def trained_home(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A data home holding model ``base``: 3 iterations of 5 episodes on the oval (a few seconds)."""
    home = tmp_path_factory.mktemp("trained_home")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("DRX_HOME", str(home))
        mp.delenv("DRX_DATABASE_URL", raising=False)
        dispose_engines()
        try:
            train_tiny(TRAINED_MODEL, episodes=15, per_iteration=5)
        finally:
            dispose_engines()
    return home


@pytest.fixture
def trained(trained_home: Path, monkeypatch: pytest.MonkeyPatch) -> str:
    """Use the trained data home (read it; write only under ``tmp_path``); returns the model's name."""
    monkeypatch.setenv("DRX_HOME", str(trained_home))
    monkeypatch.delenv("DRX_DATABASE_URL", raising=False)
    dispose_engines()
    return TRAINED_MODEL


def use_home(monkeypatch: pytest.MonkeyPatch, home: Path) -> None:
    """Switch the running test to another (empty) data home."""
    monkeypatch.setenv("DRX_HOME", str(home))
    monkeypatch.delenv("DRX_DATABASE_URL", raising=False)
    dispose_engines()
