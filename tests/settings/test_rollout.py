"""Rollout settings: worker count (1-64 or automatic) and domain randomization."""

from __future__ import annotations

import pytest

from drx.errors import SettingError
from drx.settings.rollout import RolloutSettings


def test_values() -> None:
    assert RolloutSettings() == RolloutSettings(None, False)
    assert RolloutSettings(4, 1).domain_randomization is True  # type: ignore[arg-type]


@pytest.mark.parametrize("workers", [0, 65, -1])
def test_out_of_range(workers: int) -> None:
    with pytest.raises(
        SettingError, match=rf"^rollout_workers {workers} is out of range; use 1 to 64"
    ) as info:
        RolloutSettings(workers)
    assert info.value.field == "rollout_workers"
