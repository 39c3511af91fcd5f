"""Every table of the registry, its engine and sessions, imported together (SQLAlchemy with them).

``from drx.registry import Model`` loads this module (:mod:`drx.registry`'s names are lazy), so
every table is mapped before any is used, as when the package imported them all at once; the
registry's engine imports it too. A command that reads through :mod:`drx.registry.quick` never does.
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
