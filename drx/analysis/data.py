"""What the plots and the analysis read: a model's registry rows and its trace files.

Two sources, as in DeepRacer:

- the registry (``episodes``, ``iteration_metrics``, ``checkpoints``): one row per
  episode with its reward, progress, steps and status; drawn by ``drx plot``;
- the model folder, laid out as deepracer-for-cloud lays it out: one row per step in
  ``training-simtrace/<iteration>-iteration.csv`` and, per evaluation,
  ``evaluation-<YYYYMMDDhhmmss>/evaluation-simtrace/0-iteration.csv``; read by
  ``drx analyze`` (and by the community's ``deepracer-utils``).

Trace columns are renamed as ``deepracer-utils`` renames them (``X`` -> ``x``,
``steer`` -> ``steering_angle``, ``throttle`` -> ``speed``, ``all_wheels_on_track``
-> ``on_track``), so an analysis written for one reads the other.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd
from sqlalchemy import select

from drx.errors import DrxError, NotFoundError
from drx.registry import Checkpoint, Episode, IterationMetric, Model, session_scope
from drx.services.models import get_model, model_artifacts_dir
from drx.sim.episode_status import EpisodeStatus
from drx.storage import get_store

TRAINING_SIMTRACE = "training-simtrace"
EVALUATION_SIMTRACE = "evaluation-simtrace"
EVALUATION_DIR_RE = re.compile(r"^evaluation-(\d{14})$")
TRACE_RENAMES = {
    "X": "x",
    "Y": "y",
    "steer": "steering_angle",
    "throttle": "speed",
    "all_wheels_on_track": "on_track",
}
EPISODE_COLUMNS = [
    "iteration",
    "episode",
    "phase",
    "reward",
    "progress",
    "steps",
    "status",
    "lap_time",
    "start_fraction",
    "track_name",  # the route a training episode drove (several-track models); None before 0007o
]


def model_folder(model: Model | str) -> Path:
    """The folder holding a model's checkpoints and traces (``drx model path``).

    The checkpoints' recorded paths decide (``<folder>/model/best.zip``); a model without
    checkpoints has the registry's ``$DRX_HOME/artifacts/models/<name>``, where training writes.
    With a bucket for artifacts (``DRX_ARTIFACTS_URL=s3://...``) it is this host's cache of the
    model's stored files, brought up to date first.
    """
    if isinstance(model, str):
        model = get_model(model)
    store = get_store()
    if store.remote:
        store.pull_tree(model.name)
        return model_artifacts_dir(model.name)
    with session_scope() as session:
        path = session.scalar(
            select(Checkpoint.path)
            .where(Checkpoint.model_id == model.id)
            .order_by(Checkpoint.iteration.desc())
        )
    if path:
        return Path(path).resolve().parent.parent
    return model_artifacts_dir(model.name)


@dataclass
class ModelRun:
    """A model's training history from the registry.

    :param model: the registry row (detached; attributes readable).
    :param episodes: one row per episode: ``EPISODE_COLUMNS``.
    :param metrics: one row per iteration (``iteration_metrics`` columns).
    :param checkpoints: one row per checkpoint: iteration, path, eval_progress, eval_lap_time, is_best.
    """

    model: Model
    episodes: pd.DataFrame
    metrics: pd.DataFrame
    checkpoints: pd.DataFrame

    @property
    def name(self) -> str:
        """The model's name."""
        return self.model.name

    @property
    def best_iteration(self) -> int | None:
        """The iteration of the best checkpoint (``None`` when the model has none)."""
        cps = self.checkpoints
        if cps.empty:
            return None
        best = cps[cps["is_best"]]
        row = best.iloc[-1] if not best.empty else cps.iloc[-1]
        return int(row["iteration"])

    def training_tracks(self) -> list[str]:
        """The routes the training episodes drove, in the order first driven (empty when the
        episodes do not say: a model from before several tracks)."""
        train = self.phase("training")
        return [str(t) for t in train["track_name"].dropna().unique()] if not train.empty else []

    def phase(self, phase: str) -> pd.DataFrame:
        """The episodes of one phase (``training`` or ``evaluation``), in order."""
        df = self.episodes
        return df[df["phase"] == phase].sort_values(["iteration", "episode"]).reset_index(drop=True)


def load_run(name: str) -> ModelRun:
    """Read a model's episodes, iteration metrics and checkpoints from the registry.

    :raises NotFoundError: no such model.
    """
    model = get_model(name)
    with session_scope() as session:
        eps = session.execute(
            select(*(getattr(Episode, c) for c in EPISODE_COLUMNS))
            .where(Episode.model_id == model.id)
            .order_by(Episode.phase, Episode.iteration, Episode.episode)
        ).all()
        metric_cols = [c.key for c in IterationMetric.__table__.columns if c.key not in ("id", "model_id")]
        mets = session.execute(
            select(*(getattr(IterationMetric, c) for c in metric_cols))
            .where(IterationMetric.model_id == model.id)
            .order_by(IterationMetric.iteration)
        ).all()
        cp_cols = ["iteration", "path", "steps", "episodes", "eval_progress", "eval_lap_time", "is_best"]
        cps = session.execute(
            select(*(getattr(Checkpoint, c) for c in cp_cols))
            .where(Checkpoint.model_id == model.id)
            .order_by(Checkpoint.iteration)
        ).all()
    episodes = pd.DataFrame([tuple(r) for r in eps], columns=EPISODE_COLUMNS)
    episodes["lap_time"] = pd.to_numeric(episodes["lap_time"], errors="coerce")
    return ModelRun(
        model=model,
        episodes=episodes,
        metrics=pd.DataFrame([tuple(r) for r in mets], columns=metric_cols),
        checkpoints=pd.DataFrame([tuple(r) for r in cps], columns=cp_cols).astype({"is_best": bool}),
    )


def read_trace_csv(path: Path) -> pd.DataFrame:
    """One trace file as a DataFrame with ``deepracer-utils``'s column names.

    It reads drx's own traces (a model folder's, written by :mod:`drx.train.trace` and
    :mod:`drx.analysis.eval_trace` with ``csv.writer``, which quotes a continuous action's ``[a, b]``),
    every column kept for the analysis; DeepRacer's own logs, in every layout the simulator has
    written (its unquoted actions, robomaker logs), are read by :mod:`drx.calibration.logs`.

    :raises DrxError: the file is not a DeepRacer trace.
    """
    try:
        df = pd.read_csv(path)
    except (OSError, ValueError, pd.errors.ParserError) as exc:
        raise DrxError(f"Trace {path} cannot be read as CSV ({exc}).") from exc
    df = df.rename(columns=TRACE_RENAMES)
    missing = {"episode", "steps", "x", "y", "progress"} - set(df.columns)
    if missing:
        raise DrxError(
            f"Trace {path} lacks the columns {', '.join(sorted(missing))}; it is not a DeepRacer trace."
        )
    return df


def training_trace_files(folder: Path) -> dict[int, Path]:
    """``{iteration: path}`` of a model folder's training trace files."""
    out: dict[int, Path] = {}
    for path in (Path(folder) / TRAINING_SIMTRACE).glob("*-iteration.csv"):
        stem = path.name.split("-", 1)[0]
        if stem.isdigit():
            out[int(stem)] = path
    return dict(sorted(out.items()))


def trace_tracks(trace: pd.DataFrame, episodes: pd.DataFrame) -> pd.Series:
    """The route each trace row's episode drove (``None`` where the registry does not say): the
    trace numbers an iteration's episodes by the model's running count, the registry by their
    place in the iteration, so the iteration's k-th episode in the trace is its episode k."""
    train = episodes[episodes["phase"] == "training"]
    known = {(int(r.iteration), int(r.episode)): r.track_name for r in train.itertuples()}
    place: dict[tuple[int, int], Any] = {}
    for iteration, group in trace.groupby("iteration"):
        for k, number in enumerate(sorted(group["episode"].unique())):
            place[int(iteration), int(number)] = known.get((int(iteration), k))
    keys = zip(trace["iteration"].astype(int), trace["episode"].astype(int), strict=True)
    return pd.Series([place.get(key) for key in keys], index=trace.index, dtype=object)


def load_training_trace(folder: Path, iterations: list[int] | None = None) -> pd.DataFrame:
    """The training trace of a model folder, all iterations or some, with an ``iteration`` column.

    :raises NotFoundError: the folder has no training trace (or not for these iterations).
    """
    files = training_trace_files(folder)
    if iterations is not None:
        wanted = set(iterations)
        files = {i: p for i, p in files.items() if i in wanted}
    if not files:
        which = f" for iteration {', '.join(map(str, iterations))}" if iterations else ""
        raise NotFoundError(
            f"No training trace{which} in {Path(folder) / TRAINING_SIMTRACE}; train the model first."
        )
    frames = []
    for iteration, path in files.items():
        df = read_trace_csv(path)
        df["iteration"] = iteration
        frames.append(df)
    return (
        pd.concat(frames, ignore_index=True)
        .sort_values(["episode", "steps"], kind="stable")
        .reset_index(drop=True)
    )


def evaluation_trace_files(folder: Path) -> dict[str, Path]:
    """``{YYYYMMDDhhmmss: path}`` of a model folder's evaluation traces, oldest first."""
    out: dict[str, Path] = {}
    for sub in Path(folder).glob("evaluation-*"):
        m = EVALUATION_DIR_RE.match(sub.name)
        path = sub / EVALUATION_SIMTRACE / "0-iteration.csv"
        if m and path.is_file():
            out[m.group(1)] = path
    return dict(sorted(out.items()))


def load_evaluation_trace(folder: Path) -> pd.DataFrame:
    """Every evaluation trace of a model folder, with a ``stream`` column (the evaluation's timestamp).

    :raises NotFoundError: the model has no evaluation trace.
    """
    files = evaluation_trace_files(folder)
    if not files:
        raise NotFoundError(f"No evaluation trace under {folder}; run `drx evaluate` first.")
    frames = []
    for stream, path in files.items():
        df = read_trace_csv(path)
        df["stream"] = stream
        frames.append(df)
    return pd.concat(frames, ignore_index=True)


def episode_table(trace: pd.DataFrame, by: tuple[str, ...] = ("iteration", "episode")) -> pd.DataFrame:
    """Per-episode figures of a trace: steps, progress (max), reward (sum), status (last), lap time.

    The lap time is the simulated time from the episode's first to its last step plus one
    step (DeepRacer counts the first step's frame), only for laps that completed.
    """
    keys = list(by)
    g = trace.sort_values([*keys, "steps"]).groupby(keys, sort=True)
    out = g.agg(
        steps=("steps", "count"),
        progress=("progress", "max"),
        reward=("reward", "sum"),
        status=("episode_status", "last"),
        t0=("tstamp", "first"),
        t1=("tstamp", "last"),
        start_waypoint=("closest_waypoint", "first"),
    ).reset_index()
    complete = out["status"].eq(EpisodeStatus.LAP_COMPLETE) | out["progress"].ge(100.0 - 1e-6)
    dt = (out["t1"] - out["t0"]) / (out["steps"] - 1).clip(lower=1)
    out["lap_time"] = (out["t1"] - out["t0"] + dt).where(complete)
    return out.drop(columns=["t0", "t1"])
