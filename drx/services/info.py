"""``drx info``: where drx keeps its data, what the registry holds, and the device training gets."""

from __future__ import annotations

from typing import Any

import drx
from drx.config import data_home, database_url
from drx.registry import quick
from drx.settings.car import DEFAULT_SIMULATOR, SIMULATORS

COUNTED = ("cars", "imported_tracks", "reward_sources", "models", "jobs", "checkpoints", "episodes",
           "evaluations")  # fmt: skip


def artifact_store() -> dict[str, Any]:
    """The artifact store: URL, kind, local folder (a bucket's cache), endpoint, and whether it answers."""
    from drx.errors import DrxError
    from drx.storage import get_store

    store = get_store()
    data = store.describe()
    try:
        store.check()
        data["status"] = "ok"
    except DrxError as exc:  # shown, not raised: `drx info` is where one looks when it fails
        data["status"] = str(exc)
    return data


def info() -> dict[str, Any]:
    """Version, data home, artifacts folder, database URL (password hidden), schema revision, counts,
    and the device ``auto`` trains on here with torch's build (``device``:
    :func:`drx.train.device.device_facts`; torch is imported only where it might find a GPU)."""
    from drx.train.device import device_facts

    url = database_url()
    store = artifact_store()
    counts = quick.counts()  # a current SQLite registry: read at once, no SQLAlchemy
    if counts is not None:
        shown, revision, head = url, quick.revision(), quick.revision()
    else:
        shown, revision, head, counts = _through_sqlalchemy(url)
    return {
        "version": drx.__version__,
        "data_home": str(data_home()),
        "artifacts": store["url"],
        "artifact_store": store,
        "database_url": shown,
        "schema_revision": revision,
        "schema_head": head,
        "counts": counts,
        "device": device_facts(),
        "simulator": {"new_models": DEFAULT_SIMULATOR, "cars": list(SIMULATORS)},
    }


def _through_sqlalchemy(url: str) -> tuple[str, str | None, str | None, dict[str, int]]:
    """The URL as shown (password hidden), the database's and the code's revisions and the counts,
    through SQLAlchemy (any database; it creates or migrates the registry first)."""
    from sqlalchemy import func, select
    from sqlalchemy.engine import make_url

    from drx.registry import (
        Checkpoint,
        Episode,
        Evaluation,
        Job,
        Model,
        RewardSource,
        TrackRow,
        VehicleRow,
        get_engine,
        session_scope,
    )  # fmt: skip

    columns = (VehicleRow.id, TrackRow.id, RewardSource.sha256, Model.id, Job.id, Checkpoint.id, Episode.id,
               Evaluation.id)  # fmt: skip
    engine = get_engine(url)
    with session_scope(url) as session:
        counts = {name: session.scalar(select(func.count(col))) or 0
                  for name, col in zip(COUNTED, columns, strict=True)}  # fmt: skip
        queued = session.scalar(select(func.count(Job.id)).where(Job.status.in_(("queued", "running"))))
    counts["active_jobs"] = queued or 0
    shown = make_url(url).render_as_string(hide_password=True)
    return shown, _migrate().current_revision(engine), _migrate().head_revision(), counts


def _migrate() -> Any:
    """:mod:`drx.registry.migrate`, imported when ``drx info`` runs: Alembic costs every other command
    about 0.15 s of start-up otherwise (``drx.cli.main`` imports this module)."""
    from drx.registry import migrate

    return migrate
