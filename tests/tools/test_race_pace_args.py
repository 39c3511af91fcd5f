"""benchmarks/race_pace.py refuses bad arguments in one sentence (exit 2) before it trains anything."""

from __future__ import annotations

import pytest

from ._scripts import assert_refused


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
