"""How a model's training episodes are sampled: rollout worker processes and domain randomization."""

from __future__ import annotations

from dataclasses import dataclass

from drx.errors import SettingError

MAX_ROLLOUT_WORKERS = 64


@dataclass(frozen=True)
class RolloutSettings:
    """A model's rollout settings (the ``rollout_workers`` and ``domain_randomization`` columns).

    :param rollout_workers: processes sampling training episodes, 1-64 (``None``: as many as
        help on the machine that trains, :func:`drx.train.rollout.default_rollout_workers`).
    :param domain_randomization: training episodes vary lighting and colours (DeepRacer's
        ``ENABLE_DOMAIN_RANDOMIZATION``); evaluations never do.
    :raises SettingError: ``rollout_workers`` out of range.
    """

    rollout_workers: int | None = None
    domain_randomization: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "rollout_workers", check_rollout_workers(self.rollout_workers))
        object.__setattr__(self, "domain_randomization", bool(self.domain_randomization))


def check_rollout_workers(value: int | None) -> int | None:
    """``value`` when it is a usable rollout-worker count (1-64) or ``None`` (automatic).

    :raises SettingError: out of range.
    """
    if value is None:
        return None
    if not 1 <= int(value) <= MAX_ROLLOUT_WORKERS:
        raise SettingError(
            "{field} {value} is out of range; use 1 to {hi} "
            "(or leave it out: as many as help on the machine).",
            "rollout_workers",
            value=value,
            hi=MAX_ROLLOUT_WORKERS,
        )
    return int(value)
