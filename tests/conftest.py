"""Shared test fixtures: a private data home for every test, and the real DeepRacer tracks."""

from __future__ import annotations

from collections import Counter
from pathlib import Path
from typing import Any

import pytest

# ../shared/tracks beside the checkout: real DeepRacer routes (never copied into the repo).
SHARED_TRACKS = Path(__file__).resolve().parents[1].parent / "shared" / "tracks"
SHARED_LOGS = SHARED_TRACKS.parent / "deepracer-logs"

# What each data folder beside the checkout lets the tests check; printed once when it is absent.
SHARED_DATA = {
    SHARED_TRACKS: "real DeepRacer routes: importing them, reward params, camera, render and "
    "best lap on DeepRacer's own tracks",
    SHARED_LOGS: "real DeepRacer traces: drx's car replayed against DeepRacer's simtrace logs",
}


def pytest_report_header(config: pytest.Config) -> list[str]:
    """Say at the start of the run which data folders are missing (shown unless -q)."""
    return [
        f"{folder} is absent; the tests of {what} will skip." for folder, what in SHARED_DATA.items()
        if not folder.is_dir()
    ]  # fmt: skip


def pytest_terminal_summary(terminalreporter: Any, exitstatus: int, config: pytest.Config) -> None:
    """Say once why tests skipped: per missing data folder, how many tests and what they check;
    then every other skip reason with its count."""
    per_folder: Counter[Path] = Counter()
    others: Counter[str] = Counter()
    for report in terminalreporter.stats.get("skipped", []):
        longrepr = report.longrepr
        reason = (longrepr[2] if isinstance(longrepr, tuple) else str(longrepr)).removeprefix("Skipped: ")
        folder = next((f for f in SHARED_DATA if str(f) in reason), None)
        if folder is not None:
            per_folder[folder] += 1
        else:
            others[reason] += 1
    missing = [f for f in SHARED_DATA if not f.is_dir()]
    if not (missing or per_folder or others):
        return
    terminalreporter.section("why tests skipped", sep="-")
    for folder in dict.fromkeys([*missing, *per_folder]):
        state = "is absent" if not folder.is_dir() else "lacks some files"
        terminalreporter.write_line(
            f"{folder} {state}: {per_folder[folder]} tests skipped, leaving untested {SHARED_DATA[folder]}."
        )
    for reason, count in others.most_common():
        terminalreporter.write_line(f"{count} skipped: {reason}")


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
