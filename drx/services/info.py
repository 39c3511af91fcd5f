"""``drx info``: where drx keeps its data, what the registry holds, and the device training gets."""

from __future__ import annotations

from typing import Any

from sqlalchemy import func, select
from sqlalchemy.engine import make_url

import drx
from drx.config import data_home, database_url
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
)
from drx.settings.car import DEFAULT_SIMULATOR, SIMULATORS

COUNTED = {
    "cars": VehicleRow.id,
    "imported_tracks": TrackRow.id,
    "reward_sources": RewardSource.sha256,
    "models": Model.id,
    "jobs": Job.id,
    "checkpoints": Checkpoint.id,
    "episodes": Episode.id,
    "evaluations": Evaluation.id,
}


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
    engine = get_engine(url)
    store = artifact_store()
    with session_scope(url) as session:
        counts = {name: session.scalar(select(func.count(col))) or 0 for name, col in COUNTED.items()}
        queued = session.scalar(select(func.count(Job.id)).where(Job.status.in_(("queued", "running"))))
    counts["active_jobs"] = queued or 0
    return {
        "version": drx.__version__,
        "data_home": str(data_home()),
        "artifacts": store["url"],
        "artifact_store": store,
        "database_url": make_url(url).render_as_string(hide_password=True),
        "schema_revision": _migrate().current_revision(engine),
        "schema_head": _migrate().head_revision(),
        "counts": counts,
        "device": device_facts(),
        "simulator": {"new_models": DEFAULT_SIMULATOR, "cars": list(SIMULATORS)},
    }


def _migrate() -> Any:
    """:mod:`drx.registry.migrate`, imported when ``drx info`` runs: Alembic costs every other command
    about 0.15 s of start-up otherwise (``drx.cli.main`` imports this module)."""
    from drx.registry import migrate

    return migrate
