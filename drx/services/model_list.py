"""``drx model list``'s rows, read at once: no SQLAlchemy on a current SQLite registry.

:mod:`drx.services.models` (creating, cloning, removing models) loads SQLAlchemy and the tables;
listing needs neither, so it lives apart.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from drx.registry import quick

if TYPE_CHECKING:
    from drx.registry import Model
    from drx.registry.model_settings import ModelRecord


def list_models() -> list[Model | ModelRecord]:
    """Every model, oldest first: rows with the columns and settings methods of
    :class:`~drx.registry.model_rows.Model` (:mod:`drx.registry.quick`), or the table's own rows when
    the registry must be opened through SQLAlchemy (:func:`drx.services.models.list_models`)."""
    rows = quick.models()
    if rows is not None:
        return list(rows)
    from drx.services.models import list_models as through_sqlalchemy

    return list(through_sqlalchemy())
