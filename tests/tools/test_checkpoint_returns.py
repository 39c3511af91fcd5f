"""benchmarks/checkpoint_returns.py: drives a real model's best and last checkpoints under its reward."""

from __future__ import annotations

import importlib.util
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
    returns = [float(r) for t in figures.values() for r in re.findall(r"discounted return +(-?[\d.]+)", t)]
    assert len(returns) == 4 and all(r != 0.0 for r in returns)  # the reward was summed


def test_too_few_episodes_are_refused(home: Path) -> None:
    assert_refused("checkpoint_returns.py", ["--home", str(home), "--model", "m", "--episodes", "0"],
                   "--episodes 0")  # fmt: skip


def test_the_shared_registry_of_the_environment_is_not_the_one_read(home: Path, tmp_path: Path) -> None:
    """A DRX_DATABASE_URL set for other work must not make the probe read another registry."""
    env = {**os.environ, "DRX_DATABASE_URL": f"sqlite:///{tmp_path / 'other.db'}"}
    done = subprocess.run(
        [sys.executable, str(SCRIPT), "--home", str(home), "--model", "m", "--episodes", "1"],
        capture_output=True, text=True, cwd=ROOT, timeout=300, env=env,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert "best (iteration 0) sampled" in done.stdout


class _Corridor:
    """Three steps of known rewards, the last one finishing the lap."""

    def __init__(self) -> None:
        self.t = 0

    def reset(self, seed: int, options: dict[str, float]) -> tuple[int, dict[str, float]]:
        self.t = 0
        return 0, {}

    def step(self, action: int) -> tuple[int, float, bool, bool, dict[str, float]]:
        self.t += 1
        info = {"progress": 100.0 * self.t / 3, "step_time": 0.5}
        if self.t == 3:
            info["lap_time"] = 1.5
        return self.t, float(self.t), self.t == 3, False, info


class _Driver:
    def predict(self, obs: int, deterministic: bool) -> tuple[int, None]:
        return 0, None


def test_an_episodes_returns_are_its_rewards_summed_with_and_without_the_discount(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    spec = importlib.util.spec_from_file_location("checkpoint_returns", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, "checkpoint_returns", module)  # dataclasses look their module up by name
    spec.loader.exec_module(module)
    episode = module.drive(_Corridor(), _Driver(), start=0.0, seed=0, sampled=True, discount=0.5)
    assert episode.total == 6.0  # 1 + 2 + 3
    assert episode.discounted == 1.0 + 0.5 * 2.0 + 0.25 * 3.0
    assert episode.finished and episode.progress == 100.0 and episode.seconds == 1.5
