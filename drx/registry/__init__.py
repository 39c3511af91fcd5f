"""drx's registry: the SQLAlchemy 2.x tables, engine/sessions and Alembic migrations.

Every table is importable from here::

    from drx.registry import Job, Model, session_scope

The schema is brought to the newest revision automatically the first time an
engine is used (:func:`get_engine`). Raw SQL lives only in this package.
"""

from drx.registry.base import Base, utcnow
from drx.registry.engine import dispose_engines, get_engine, session_scope
from drx.registry.evaluations import Evaluation, EvaluationLap
from drx.registry.job_rows import JOB_ACTIVE_STATUSES, JOB_FINAL_STATUSES, JOB_STATUSES, Job
from drx.registry.metrics import EPISODE_PHASES, Checkpoint, Episode, IterationMetric
from drx.registry.model_rows import ALGORITHMS, MODEL_STATUSES, Model
from drx.registry.race_rows import Race, RaceEntry
from drx.registry.reward_rows import RewardSource, code_sha256
from drx.registry.track_rows import TrackRow
from drx.registry.vehicle_rows import VehicleRow

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
