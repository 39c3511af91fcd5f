"""Shared test fixtures: a private data home for every test, and the real DeepRacer tracks."""

from __future__ import annotations

from pathlib import Path

import pytest

# ../shared/tracks beside the checkout: real DeepRacer routes (never copied into the repo).
SHARED_TRACKS = Path(__file__).resolve().parents[1].parent / "shared" / "tracks"


@pytest.fixture(autouse=True)
def _drx_home(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """Point ``DRX_HOME`` at a fresh temporary folder so tests never touch ``~/.drx``."""
    home = tmp_path / "drx_home"
    monkeypatch.setenv("DRX_HOME", str(home))
    # evaluations without --seed repeat from run to run in tests (the simulator's noise is seeded)
    monkeypatch.setenv("DRX_EVALUATION_SEED", "0")
    return home


def shared_track_path(name: str) -> Path:
    """Path of a real DeepRacer route in ``../shared/tracks``; skips the test when it is absent."""
    path = SHARED_TRACKS / f"{name}.npy"
    if not path.is_file():
        pytest.skip(f"{path} is absent: the real DeepRacer tracks live in ../shared/tracks beside the repo")
    return path


@pytest.fixture
def shared_tracks() -> Path:
    """The ``../shared/tracks`` folder; skips the test when it is absent."""
    if not SHARED_TRACKS.is_dir():
        pytest.skip(f"{SHARED_TRACKS} is absent: the real DeepRacer tracks live in ../shared/tracks")
    return SHARED_TRACKS
