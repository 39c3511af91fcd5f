"""benchmarks/best_lap.py refuses bad arguments in one sentence (exit 2) before it solves anything."""

from __future__ import annotations

import pytest

from ._scripts import assert_refused


@pytest.mark.parametrize(
    ("args", "named"),
    [
        (["--tracks", "no_such_track"], "--tracks no_such_track is not a shipped track"),
        (["--speed-scales", "0"], "--speed-scales 0 is not above 0"),
    ],
)
def test_bad_arguments_end_in_one_sentence_and_exit_2(args: list[str], named: str) -> None:
    done = assert_refused("best_lap.py", args, named)
    assert "track " not in done.stdout  # no table started
