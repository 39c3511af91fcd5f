"""drx's registry: the SQLAlchemy 2.x tables, engine/sessions and Alembic migrations.

Every table is importable from here::

    from drx.registry import Job, Model, session_scope

The schema is brought to the newest revision automatically the first time an
engine is used (:func:`get_engine`). Raw SQL lives only in this package.

The names load on first use (:mod:`drx.registry.tables`, with SQLAlchemy): importing a
SQLAlchemy-free submodule such as :mod:`drx.registry.quick` (the everyday listings' reads) costs
nothing more.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from drx.registry.tables import (
        ALGORITHMS,
        EPISODE_PHASES,
        JOB_ACTIVE_STATUSES,
        JOB_FINAL_STATUSES,
        JOB_STATUSES,
        MODEL_STATUSES,
        Base,
        Checkpoint,
        Episode,
        Evaluation,
        EvaluationLap,
        IterationMetric,
        Job,
        Model,
        Race,
        RaceEntry,
        RewardSource,
        TrackRow,
        VehicleRow,
        code_sha256,
        dispose_engines,
        get_engine,
        session_scope,
        utcnow,
    )

__all__ = [
    "ALGORITHMS",
    "EPISODE_PHASES",
    "JOB_ACTIVE_STATUSES",
    "JOB_FINAL_STATUSES",
    "JOB_STATUSES",
    "MODEL_STATUSES",
    "Base",
    "Checkpoint",
    "Episode",
    "Evaluation",
    "EvaluationLap",
    "IterationMetric",
    "Job",
    "Model",
    "Race",
    "RaceEntry",
    "RewardSource",
    "TrackRow",
    "VehicleRow",
    "code_sha256",
    "dispose_engines",
    "get_engine",
    "session_scope",
    "utcnow",
]


def __getattr__(name: str) -> Any:
    """A name of :mod:`drx.registry.tables`, which loads (every table at once) on first use."""
    if name not in __all__:
        raise AttributeError(f"module 'drx.registry' has no attribute {name!r}")
    tables = importlib.import_module("drx.registry.tables")
    for exported in __all__:
        globals()[exported] = getattr(tables, exported)
    return globals()[name]
