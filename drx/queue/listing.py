"""``drx jobs list``'s rows, read at once: no SQLAlchemy on a current SQLite registry.

:mod:`drx.queue.lifecycle` (every change of a job's state) loads SQLAlchemy and the tables; a
listing needs neither, so it lives apart.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from drx.registry import quick

if TYPE_CHECKING:
    from drx.registry import Job


def list_jobs(
    status: str | None = None, model_name: str | None = None, limit: int = 50
) -> list[tuple[Job | quick.Record, str]]:
    """Recent jobs (newest first) with their model's name: rows with the columns of
    :class:`~drx.registry.job_rows.Job` (:mod:`drx.registry.quick`), or the table's own rows when the
    registry must be opened through SQLAlchemy (:func:`drx.queue.lifecycle.list_jobs`)."""
    rows = quick.jobs(status, model_name, limit)
    if rows is not None:
        return list(rows)
    from drx.queue.lifecycle import list_jobs as through_sqlalchemy

    return list(through_sqlalchemy(status=status, model_name=model_name, limit=limit))
