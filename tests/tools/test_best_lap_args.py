"""benchmarks/best_lap.py refuses bad arguments in one sentence (exit 2) before it solves anything."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize(
    ("args", "named"),
    [
        (["--tracks", "no_such_track"], "--tracks no_such_track is not a shipped track"),
        (["--speed-scales", "0"], "--speed-scales 0 is not above 0"),
    ],
)
def test_bad_arguments_end_in_one_sentence_and_exit_2(args: list[str], named: str) -> None:
    done = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / "best_lap.py"), *args],
        capture_output=True, text=True, cwd=ROOT, timeout=120,
    )  # fmt: skip
    assert done.returncode == 2, done.stderr
    assert named in done.stderr and "Traceback" not in done.stderr
    assert "track " not in done.stdout  # no table started
