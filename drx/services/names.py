"""One name rule for everything a user names: models, cars and tracks.

1 to 64 letters, digits, '-' and '_', starting with a letter or digit. DeepRacer's own track
files use '_' (e.g. ``reInvent2019_wide_cw``), so every kind of name takes it; a leading '-'
would read as an option on the command line.
"""

from __future__ import annotations

import re

from drx.errors import DrxError

NAME_RULE = "1 to 64 letters, digits, '-' and '_', starting with a letter or digit"
ITEM_NAME_RE = re.compile(r"[A-Za-z0-9][A-Za-z0-9_-]{0,63}")
MODEL_NAME_RE = ITEM_NAME_RE  # the same rule (kept for callers that import it)


def check_item_name(name: str, what: str) -> str:
    """Return ``name`` if it follows the name rule (:data:`NAME_RULE`).

    :param what: the kind of name, for the sentence (``"car"``, ``"track"``, ``"model"``).
    :raises DrxError: naming the value and the rule.
    """
    if not ITEM_NAME_RE.fullmatch(name):
        raise DrxError(f"{what.capitalize()} name {name!r} is not allowed; use {NAME_RULE}.")
    return name


def check_model_name(name: str) -> str:
    """Return ``name`` if it is a valid model name (the one rule, :data:`NAME_RULE`)."""
    return check_item_name(name, "model")
