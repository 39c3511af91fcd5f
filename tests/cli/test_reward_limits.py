"""`drx reward validate` on rewards that loop, sleep, exit or print: exit 2, one sentence, clean --json."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from .helpers import fails, write

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(autouse=True)
def _short_limit(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("DRX_REWARD_TIME_LIMIT", "0.2")


@pytest.mark.parametrize(
    "body",
    [
        "def reward_function(params):\n    while True:\n        pass\n",
        "import time\n\n\ndef reward_function(params):\n    time.sleep(1)\n",  # ended early or on return
    ],
    ids=["loop", "sleep"],
)
def test_a_reward_over_the_time_limit_fails_validation(tmp_path: Path, body: str) -> None:
    path = write(tmp_path / "slow.py", body)
    fails(
        "reward", "validate", str(path), contains=("5 of 5", "ran longer than 0.2 s", "DRX_REWARD_TIME_LIMIT")
    )


def _drx_json(*args: str) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run(
        [sys.executable, "-m", "drx.cli.main", *args, "--json"],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )


def test_os_exit_is_reported_and_json_is_written(tmp_path: Path) -> None:
    path = write(tmp_path / "exit.py", "import os\n\n\ndef reward_function(params):\n    os._exit(0)\n")
    proc = _drx_json("reward", "validate", str(path))
    assert proc.returncode == 2
    report = json.loads(proc.stdout)
    assert not report["ok"] and "called os._exit(0)" in report["cases"][0]["error"]
    assert proc.stderr.strip().startswith("Error: ") and "Traceback" not in proc.stderr


def test_sys_exit_is_reported(tmp_path: Path) -> None:
    path = write(tmp_path / "sysexit.py", "import sys\n\n\ndef reward_function(params):\n    sys.exit(3)\n")
    fails("reward", "validate", str(path), contains="called sys.exit(3)")


def test_a_printing_reward_keeps_json_clean(tmp_path: Path) -> None:
    path = write(
        tmp_path / "chatty.py",
        "def reward_function(params):\n    print('hello', params['steps'])\n    return 1.0\n",
    )
    proc = _drx_json("reward", "validate", str(path))
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["ok"]  # stdout is the JSON document alone
    assert "hello" in proc.stderr
