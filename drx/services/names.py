"""Name rules for models, cars and tracks."""

from __future__ import annotations

import re

from drx.errors import DrxError

MODEL_NAME_RE = re.compile(r"[A-Za-z0-9-]{1,64}")
# Cars and tracks also allow '_' (DeepRacer's own track files use it, e.g. reInvent2019_wide_cw).
ITEM_NAME_RE = re.compile(r"[A-Za-z0-9][A-Za-z0-9_-]{0,63}")


def check_model_name(name: str) -> str:
    """Return ``name`` if it is a valid DeepRacer model name (1-64 letters, digits and '-')."""
    if not MODEL_NAME_RE.fullmatch(name):
        raise DrxError(
            f"Model name {name!r} is not allowed; use 1 to 64 characters of letters, digits and '-'."
        )
    return name


def check_item_name(name: str, what: str) -> str:
    """Return ``name`` if it is a valid car or track name (1-64 letters, digits, '-' and '_')."""
    if not ITEM_NAME_RE.fullmatch(name):
        raise DrxError(
            f"{what.capitalize()} name {name!r} is not allowed; use 1 to 64 letters, digits, '-' and '_', "
            "starting with a letter or digit."
        )
    return name
