"""benchmarks/ab_revisions.py, sac_throughput.py and cli_startup.py refuse bad arguments in one
sentence (exit 2) before they check out a revision, train or time anything."""

from __future__ import annotations

import pytest

from ._scripts import assert_refused


@pytest.mark.parametrize(
    ("args", "named"),
    [
        (["--figure", "(x)"], "give the benchmark to run after --"),
        (["--rounds", "0", "--figure", "(x)", "--", "true"], "--rounds 0 is below 1"),
        (["--figure", "(", "--", "true"], "--figure '(' is not a regular expression"),
        (["--figure", "x", "--", "true"], "--figure 'x' has no group"),
        (
            ["--base", "no-such-rev", "--figure", "(x)", "--", "true"],
            "--base 'no-such-rev' is not a git revision",
        ),
    ],
)
def test_ab_revisions_refuses_bad_arguments(args: list[str], named: str) -> None:
    done = assert_refused("ab_revisions.py", args, named)
    assert "round 1" not in done.stdout


def test_sac_throughput_refuses_a_run_of_nothing() -> None:
    done = assert_refused("sac_throughput.py", ["--repeats", "0"], "--repeats 0 must be above 0")
    assert "steps/s" not in done.stdout


@pytest.mark.parametrize(
    ("args", "named"),
    [
        (["--runs", "0"], "--runs 0 is below 1"),
        (["--base", "no-such-rev"], "--base 'no-such-rev' is not a git revision"),
    ],
)
def test_cli_startup_refuses_bad_arguments(args: list[str], named: str) -> None:
    done = assert_refused("cli_startup.py", args, named)
    assert "cores:" not in done.stdout
