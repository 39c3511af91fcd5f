"""``drx train``'s own options are checked before a job is queued: one sentence, exit 2, no job."""

from __future__ import annotations

from pathlib import Path

import pytest

from .helpers import fails_unchanged, ok


@pytest.mark.parametrize("seed", ["-1", "4294967296"])
def test_a_seed_out_of_range_queues_nothing(seed: str) -> None:
    ok("model", "create", "m")
    fails_unchanged("train", "m", "--seed", seed, "--detach", contains=(f"--seed {seed}", "0 to 4294967295"))


def test_a_missing_checkpoint_queues_nothing(tmp_path: Path) -> None:
    ok("model", "create", "m")
    missing = tmp_path / "nowhere.zip"
    fails_unchanged("train", "m", "--checkpoint", str(missing), "--detach", contains=("not exist", ".zip"))
    fails_unchanged("train", "m", "--checkpoint", str(tmp_path), "--detach", contains="is a folder")
