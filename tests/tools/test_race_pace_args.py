"""benchmarks/race_pace.py refuses bad arguments in one sentence (exit 2) before it trains anything."""

from __future__ import annotations

import importlib.util
import sys

import pytest

from ._scripts import ROOT, assert_refused


@pytest.mark.parametrize(
    ("args", "named"),
    [
        (["--reward", "no-such-reward.py"], "--reward"),
        (["--track", "no_such_track"], "--track"),
        (["--minutes", "0"], "--minutes"),
        (["--algo", "sac"], "SAC trains continuous cars only"),
        (["--sac-alpha", "0.1", "--only", "exp2"], "--sac-alpha 0.1 needs --algo sac"),
        (["--algo", "sac", "--sac-alpha", "2", "--only", "exp2"], "--sac-alpha 2 needs"),
        (["--lr-schedule", "cosine", "--only", "exp2"], "--lr-schedule: invalid choice: 'cosine'"),
        (["--rollout-workers", "0", "--only", "exp2"], "--rollout-workers 0 is out of range"),
    ],
)
def test_bad_arguments_end_in_one_sentence_and_exit_2(args: list[str], named: str) -> None:
    done = assert_refused("race_pace.py", args, named)
    assert "race pace on" not in done.stdout  # nothing started


def test_each_run_gets_a_fresh_home_not_the_shared_registry(monkeypatch: pytest.MonkeyPatch) -> None:
    """A DRX_DATABASE_URL or DRX_ARTIFACTS_URL set for other work must not receive the benchmark's models."""
    spec = importlib.util.spec_from_file_location("race_pace", ROOT / "benchmarks" / "race_pace.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, "race_pace", module)  # dataclasses look their module up by name
    spec.loader.exec_module(module)
    monkeypatch.setenv("DRX_DATABASE_URL", "postgresql://shared/drx")
    monkeypatch.setenv("DRX_ARTIFACTS_URL", "s3://shared")
    env = module.Home("/tmp/fresh-home").env
    assert env["DRX_HOME"] == "/tmp/fresh-home"
    assert "DRX_DATABASE_URL" not in env and "DRX_ARTIFACTS_URL" not in env
