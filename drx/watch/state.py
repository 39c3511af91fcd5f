"""What the watch page shows besides the pictures, read from what workers already write.

The registry gives the model, its newest job (status, worker, start, stop conditions) and one
``iteration_metrics`` row per finished iteration: the reward graph's points, as the DeepRacer
console draws them (average reward and average percentage completion of the training episodes,
average percentage completion of the evaluation episodes, per iteration). The live pose files
(:mod:`drx.watch.live`) tell the phase: a training env stepping is "sampling episodes", an
evaluation env stepping is "evaluating", a running training job whose envs are quiet is updating
its policy. Nothing here writes.
"""

from __future__ import annotations

import time
from datetime import datetime
from pathlib import Path
from typing import Any

from sqlalchemy import desc, func, select

from drx.errors import NotFoundError
from drx.registry import Checkpoint, Episode, Evaluation, IterationMetric, Job, Model, session_scope
from drx.registry.metrics import iterations_so_far
from drx.services.models import model_artifacts_dir
from drx.sim.episode_status import EpisodeStatus
from drx.watch.live import is_live, latest_pose

# Phases, as the page shows them.
NO_JOB = "no job yet"
QUEUED = "queued: waiting for a worker"
STARTING = "starting"
SAMPLING = "sampling episodes"
UPDATING = "updating the policy"
EVALUATING = "evaluating"
RACING = "racing (evaluation job)"
EVALUATING_HERE = "racing (drx evaluate)"
POSE_GRACE = 5.0  # [s] a pose file's env may be made a moment before its job's start is stored


def resolve_model(name: str | None) -> str | None:
    """The model to watch: ``name`` (checked), else the model of the newest running job, else of
    the newest job, else the newest model; ``None`` when there is no model yet.

    :raises NotFoundError: ``name`` names no model.
    """
    with session_scope() as session:
        if name is not None:
            if session.scalar(select(Model.id).where(Model.name == name)) is None:
                names = list(session.scalars(select(Model.name).order_by(Model.name).limit(12)))
                hint = f"known models: {', '.join(names)}" if names else "there are no models yet"
                raise NotFoundError(f"No model named {name!r}; {hint} (see `drx model list`).")
            return name
        for query in (
            select(Model.name).join(Job, Job.model_id == Model.id).where(Job.status == "running")
            .order_by(desc(Job.started_at), desc(Job.id)),
            select(Model.name).join(Job, Job.model_id == Model.id).order_by(desc(Job.id)),
            select(Model.name).order_by(desc(Model.created_at), desc(Model.id)),
        ):  # fmt: skip
            found = session.scalar(query.limit(1))
            if found is not None:
                return str(found)
    return None


def running_jobs() -> list[dict[str, Any]]:
    """Every running or queued job on this registry: id, kind, status and model, newest first."""
    with session_scope() as session:
        rows = session.execute(
            select(Job.id, Job.kind, Job.status, Model.name)
            .join(Model, Model.id == Job.model_id)
            .where(Job.status.in_(("running", "queued")))
            .order_by(desc(Job.id))
            .limit(20)
        ).all()
    return [{"id": r[0], "kind": r[1], "status": r[2], "model": r[3]} for r in rows]


def _iso(value: datetime | None) -> str | None:
    return value.isoformat() if value is not None else None


def _seconds(value: datetime | None) -> float | None:
    return value.timestamp() if value is not None else None


def _job_dict(job: Job | None, now: float) -> dict[str, Any] | None:
    if job is None:
        return None
    started = _seconds(job.started_at)
    ended = _seconds(job.finished_at)
    # wall time since the job started (a queued job's start is an earlier attempt's: none shown)
    elapsed = None
    if job.status != "queued" and started is not None:
        elapsed = max(0.0, (ended if ended is not None else now) - started)
    return {
        "id": job.id,
        "kind": job.kind,
        "status": job.status,
        "worker": job.worker_id,
        "started_at": _iso(job.started_at),
        "finished_at": _iso(job.finished_at),
        "elapsed": elapsed,
        "stop_reason": job.stop_reason,
        "error": (job.error or "").strip().splitlines()[0] if job.error else None,
        "attempts": job.attempts,
    }


def phase_of(job: dict[str, Any] | None, pose: dict[str, Any] | None, now: float) -> str:
    """The job's phase from its status and the freshness and kind of the newest pose."""
    if job is None or job["status"] != "running":
        if is_live(pose, now):  # `drx evaluate` races in the foreground without a job
            return EVALUATING_HERE if pose and pose.get("mode") == "evaluation" else SAMPLING
        if job is None:
            return NO_JOB
        if job["status"] == "queued":
            return QUEUED
        reason = job.get("error") or job.get("stop_reason")
        return f"{job['status']}: {reason}" if reason else job["status"]
    started = now - float(job.get("elapsed") or 0.0)
    ours = pose is not None and float(pose.get("started", 0.0)) >= started - POSE_GRACE
    if job["kind"] != "train":
        return RACING if ours and is_live(pose, now) else STARTING
    if not ours:
        return STARTING
    if is_live(pose, now):
        return EVALUATING if pose and pose.get("mode") == "evaluation" else SAMPLING
    return UPDATING


def _graph(rows: list[IterationMetric]) -> dict[str, list[Any]]:
    """The reward graph's series, one point per iteration (``None`` where a value is missing)."""
    return {
        "iteration": [r.iteration for r in rows],
        "train_reward": [r.train_mean_reward for r in rows],
        "train_progress": [r.train_mean_progress for r in rows],
        "eval_reward": [r.eval_mean_reward for r in rows],
        "eval_progress": [r.eval_mean_progress for r in rows],
    }


def _pose_dict(pose: dict[str, Any] | None, now: float) -> dict[str, Any] | None:
    if pose is None:
        return None
    keys = ("mode", "episode", "steps", "progress", "speed", "steering", "status", "reward", "track")
    return {**{k: pose.get(k) for k in keys}, "age": max(0.0, now - float(pose.get("time", now)))}


def snapshot(name: str | None, now: float | None = None) -> dict[str, Any]:
    """Everything the page shows about model ``name`` (``None``: nothing to watch yet), as JSON.

    :raises NotFoundError: the model was removed.
    """
    now = time.time() if now is None else now
    if name is None:
        return {"model": None, "phase": NO_JOB, "job": None, "jobs": running_jobs(), "now": now,
                "graph": _graph([]), "figures": {}, "pose": None}  # fmt: skip
    with session_scope() as session:
        model = session.scalar(select(Model).where(Model.name == name))
        if model is None:
            raise NotFoundError(f"No model named {name!r} (was it removed?).")
        job = session.scalar(select(Job).where(Job.model_id == model.id).order_by(desc(Job.id)).limit(1))
        rows, current = iterations_so_far(session, model.id)
        last_it = rows[-1].iteration if rows else -1
        best = session.scalar(
            select(Checkpoint).where(Checkpoint.model_id == model.id, Checkpoint.is_best.is_(True)).limit(1)
        )
        best_lap = session.scalar(
            select(func.min(Episode.lap_time)).where(
                Episode.model_id == model.id,
                Episode.phase == "evaluation",
                Episode.status == EpisodeStatus.LAP_COMPLETE.value,
            )
        )
        race = None
        if job is not None and job.kind == "evaluate":
            race = session.scalar(select(Evaluation).where(Evaluation.job_id == job.id).limit(1))
        job_d = _job_dict(job, now)
        hp = model.hyperparameter_settings()
        stop = model.stop_settings((job.options or {}).get("stop") if job is not None else None)
        info = {
            "model": model.name,
            "model_status": model.status,
            "track": model.track_name,
            "tracks": [t.name for t in model.episode_settings().tracks],  # several: episodes take turns
            "car": model.vehicle_name,
            "network": (model.vehicle_spec or {}).get("network"),
            "algorithm": model.algorithm,
        }
    pose = latest_pose(model_artifacts_dir(name), now)
    last = rows[-1] if rows else None
    figures: dict[str, Any] = {
        "iteration": last_it + 1,
        "iterations_done": len(rows),
        "iteration_episodes": int(current or 0),
        "episodes_per_iteration": hp.episodes_per_iteration,
        "steps": last.steps if last else 0,
        "episodes": (last.episodes if last else 0) + int(current or 0),
        "steps_per_second": last.steps_per_second if last else None,
        "best_eval_progress": best.eval_progress if best is not None else None,
        "best_iteration": best.iteration if best is not None else None,
        "best_lap_time": best_lap,
        **stop.to_dict(),
    }
    if race is not None:
        figures.update(
            race_laps=race.laps_completed, race_fastest_lap=race.fastest_lap, race_status=race.status
        )
    return {
        **info,
        "now": now,
        "job": job_d,
        "phase": phase_of(job_d, pose, now),
        "pose": _pose_dict(pose, now),
        "figures": figures,
        "graph": _graph(rows),
        "jobs": running_jobs(),
    }


def model_folder(name: str) -> Path:
    """The model's artifacts folder (where its live pose files are)."""
    return model_artifacts_dir(name)
