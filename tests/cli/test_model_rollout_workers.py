"""``--rollout-workers`` on ``drx model create|clone`` and ``drx train``."""

from __future__ import annotations

import pytest

from .helpers import fails_unchanged, ok, ok_json


def test_stored_inherited_and_shown() -> None:
    assert ok_json("model", "create", "auto")["rollout_workers"] is None
    assert ok_json("model", "create", "two", "--rollout-workers", "2")["rollout_workers"] == 2
    assert ok_json("model", "clone", "two", "kid")["rollout_workers"] == 2  # the parent's
    assert ok_json("model", "clone", "two", "kid4", "--rollout-workers", "4")["rollout_workers"] == 4
    assert "automatic" in ok("model", "show", "auto").stdout


@pytest.mark.parametrize("value", ["0", "65", "-1"])
def test_out_of_range_exits_2_and_changes_nothing(value: str) -> None:
    fails_unchanged("model", "create", "m", "--rollout-workers", value, contains=(value, "1 to 64"))


def test_train_option_out_of_range_queues_nothing() -> None:
    ok("model", "create", "m")
    fails_unchanged("train", "m", "--rollout-workers", "0", "--detach", contains=("0", "1 to 64"))


def test_train_detach_json_names_the_job() -> None:
    ok("model", "create", "m")
    queued = ok_json("train", "m", "--rollout-workers", "2", "--detach")
    assert queued == {"job": 1, "model": "m", "status": "queued"}
