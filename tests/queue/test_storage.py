"""A full disk and a read-only home: one sentence, exit 2; nothing left `running`; a read-only home lists.

Both need a small tmpfs (``mount``, root only); they skip with the reason elsewhere.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import uuid
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DRX = [sys.executable, "-m", "drx.cli.main"]


@pytest.fixture
def tmpfs(tmp_path: Path) -> Iterator[Path]:
    """A 6 MB tmpfs (a compact model's two checkpoints take 4 MB); skipped where mounting is impossible."""
    mount = tmp_path / f"tmpfs-{uuid.uuid4().hex[:6]}"
    mount.mkdir()
    proc = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=6m", "tmpfs", str(mount)], capture_output=True)
    if proc.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here ({proc.stderr.decode().strip() or 'not root'})")
    try:
        yield mount
    finally:
        subprocess.run(["umount", "-l", str(mount)], capture_output=True)


def _drx(home: Path, *args: str, timeout: float = 300) -> subprocess.CompletedProcess[str]:
    env = {
        **os.environ, "DRX_HOME": str(home), "PYTHONPATH": str(ROOT), "DRX_TORCH_THREADS": "1",
    }  # fmt: skip
    env.pop("DRX_DATABASE_URL", None)
    return subprocess.run([*DRX, *args], capture_output=True, text=True, env=env, timeout=timeout)


def _one_sentence(proc: subprocess.CompletedProcess[str], contains: str) -> None:
    assert proc.returncode == 2, proc.stderr[-2000:]
    err = proc.stderr.strip()
    assert err.startswith("Error: ") and "\n" not in err and "Traceback" not in err, err[-2000:]
    assert contains in err, err


@pytest.mark.slow  # ~50 s: trains until the 6 MB disk is full
def test_a_full_disk_during_training(tmpfs: Path) -> None:
    home = tmpfs / "home"
    create = (
        "model",
        "create",
        "m",
        "--track",
        "oval",
        "--network",
        "compact",
        "--episodes-per-iteration",
        "5",
    )
    assert _drx(home, *create).returncode == 0
    _one_sentence(_drx(home, "train", "m", "--max-episodes", "500"), "is full; free some space")
    subprocess.run(["mount", "-o", "remount,size=64m", str(tmpfs)], check=True)
    # The next `drx train` is not refused: the dead run's job leaves `running` with its reason.
    again = _drx(home, "train", "m", "--detach")
    assert again.returncode == 0, again.stderr
    first = json.loads(_drx(home, "jobs", "show", "1", "--json").stdout)
    assert first["status"] == "failed" and first["attempt_log"]
    assert "is full" in first["error"] or "died" in first["error"]
    model = next(m for m in json.loads(_drx(home, "model", "list", "--json").stdout) if m["name"] == "m")
    assert model["status"] == "queued"
    assert first["training_episodes"] % 5 == 0  # whole iterations only: rows past the last checkpoint went


def test_a_read_only_home_lists_and_refuses_changes(tmpfs: Path) -> None:
    home = tmpfs / "home"
    assert _drx(home, "model", "create", "m", "--track", "oval").returncode == 0
    subprocess.run(["mount", "-o", "remount,ro", str(tmpfs)], check=True)
    listed = _drx(home, "model", "list")
    assert listed.returncode == 0 and " m " in listed.stdout, listed.stderr
    assert _drx(home, "jobs", "list").returncode == 0
    _one_sentence(_drx(home, "model", "create", "m2", "--track", "oval"), "is read-only")
