"""The seed that makes a training, an evaluation or a sweep repeatable: its one range.

numpy's ``SeedSequence`` and ``RandomState`` (under SB3, the episode seeds and the step-time noise) and
Optuna's samplers all take whole numbers from 0 to 2**32 - 1; anything else is refused up front, before
a job is queued or a row stored.
"""

from __future__ import annotations

from drx.errors import SettingError

MAX_SEED = 2**32 - 1


def check_seed(value: int | None) -> int | None:
    """``value`` when it is a usable seed (a whole number from 0 to 4294967295) or ``None`` (unseeded).

    :raises SettingError: anything else.
    """
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= MAX_SEED:
        raise SettingError(
            "{field} {value!r} is out of range; use a whole number from 0 to {hi}.",
            "seed",
            value=value,
            hi=MAX_SEED,
        )
    return value
