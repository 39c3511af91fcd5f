"""benchmarks/checkpoint_returns.py: drives a real model's best and last checkpoints under its reward."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from ._scripts import ROOT, assert_refused

SCRIPT = ROOT / "benchmarks" / "checkpoint_returns.py"


def _drx(home: Path, *args: str) -> None:
    env = {**os.environ, "DRX_HOME": str(home)}
    env.pop("DRX_DATABASE_URL", None)
    subprocess.run([sys.executable, "-m", "drx.cli.main", *args, "--json"], check=True,
                   capture_output=True, env=env, cwd=ROOT, timeout=300)  # fmt: skip


@pytest.fixture(scope="module")
def home(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A data home with model ``m``: one iteration of 5 episodes on the oval, so best is last."""
    folder = tmp_path_factory.mktemp("returns_home")
    _drx(folder, "model", "create", "m", "--max-episodes", "5", "--episodes-per-iteration", "5",
         "--epochs", "3")  # fmt: skip
    _drx(folder, "train", "m", "--seed", "0")
    return folder


def test_a_home_without_a_registry_is_refused(tmp_path: Path) -> None:
    assert_refused("checkpoint_returns.py", ["--home", str(tmp_path), "--model", "m"], "--home")


def test_an_unknown_model_is_refused_in_one_sentence(home: Path) -> None:
    assert_refused("checkpoint_returns.py", ["--home", str(home), "--model", "nosuch"], "'nosuch'")


def test_each_checkpoint_is_driven_both_ways_from_the_same_starts(home: Path) -> None:
    done = subprocess.run(
        [sys.executable, str(SCRIPT), "--home", str(home), "--model", "m", "--episodes", "2"],
        capture_output=True, text=True, cwd=ROOT, timeout=300,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    rows = re.findall(r"^  (best|last) \(iteration 0\) (sampled|most probable): (.*)$", done.stdout, re.M)
    assert [(c, w) for c, w, _ in rows] == [
        ("best", "sampled"), ("best", "most probable"), ("last", "sampled"), ("last", "most probable")
    ]
    figures = {(c, w): text for c, w, text in rows}
    # One iteration: best and last are the same weights, so the same starts and noise give the same figures.
    assert figures["best", "sampled"] == figures["last", "sampled"]
    assert figures["best", "most probable"] == figures["last", "most probable"]
    returns = [float(re.search(r"discounted return +(-?[\d.]+)", t).group(1)) for t in figures.values()]
    assert all(r != 0.0 for r in returns)  # the reward was summed
