"""Running a script of ``benchmarks/`` as a user would, to check how it refuses bad arguments."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def assert_refused(script: str, args: list[str], named: str) -> subprocess.CompletedProcess[str]:
    """Run ``benchmarks/SCRIPT ARGS`` and check it ended in exit 2 with one sentence naming ``named``
    on stderr and no traceback; return the run, for what its output must not hold."""
    done = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks" / script), *args],
        capture_output=True, text=True, cwd=ROOT, timeout=120,
    )  # fmt: skip
    assert done.returncode == 2, done.stderr
    assert named in done.stderr and "Traceback" not in done.stderr
    return done
