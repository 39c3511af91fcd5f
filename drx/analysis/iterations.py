"""The per-iteration table of ``drx analyze``: completion rate, mean progress and lap times."""

from __future__ import annotations

import numpy as np
import pandas as pd

from drx.sim.episode_status import EpisodeStatus

_PHASE_COLUMNS = [
    "iteration",
    "episodes",
    "completion_rate",
    "mean_progress",
    "mean_reward",
    "best_lap_time",
    "mean_lap_time",
]
ITERATION_COLUMNS = [
    *_PHASE_COLUMNS,
    "eval_episodes",
    "eval_mean_progress",
    "eval_best_lap_time",
]


def _complete(df: pd.DataFrame) -> pd.Series:
    return df["status"].eq(EpisodeStatus.LAP_COMPLETE) | df["progress"].ge(100.0 - 1e-6)


def _phase_table(df: pd.DataFrame) -> pd.DataFrame:
    if df.empty:
        return pd.DataFrame(columns=_PHASE_COLUMNS)
    df = df.assign(complete=_complete(df), lap=df["lap_time"].where(_complete(df)).astype(float))
    g = df.groupby("iteration")
    return pd.DataFrame(
        {
            "episodes": g.size(),
            "completion_rate": g["complete"].mean() * 100.0,
            "mean_progress": g["progress"].mean(),
            "mean_reward": g["reward"].mean(),
            "best_lap_time": g["lap"].min(),
            "mean_lap_time": g["lap"].mean(),
        }
    ).reset_index()


def iteration_table(episodes: pd.DataFrame) -> pd.DataFrame:
    """One row per iteration from per-episode rows (``phase``, ``iteration``, ``progress``, ``status``,
    ``reward``, ``lap_time``): training completion rate [%], mean progress [%], mean reward, best and
    mean complete-lap times [s], and the same for the evaluation episodes."""
    train = _phase_table(episodes[episodes["phase"] == "training"])
    evals = _phase_table(episodes[episodes["phase"] == "evaluation"]).rename(
        columns={
            "episodes": "eval_episodes",
            "mean_progress": "eval_mean_progress",
            "best_lap_time": "eval_best_lap_time",
        }
    )[["iteration", "eval_episodes", "eval_mean_progress", "eval_best_lap_time"]]
    table = train.merge(evals, on="iteration", how="outer").sort_values("iteration")
    for col in ("episodes", "eval_episodes"):
        table[col] = table[col].fillna(0).astype(int)
    table["iteration"] = table["iteration"].astype(int)
    return table[ITERATION_COLUMNS].reset_index(drop=True)


def overall(episodes: pd.DataFrame) -> dict[str, float | int | None]:
    """Totals over every training episode: count, completion rate, mean/best progress, best lap."""
    train = episodes[episodes["phase"] == "training"]
    if train.empty:
        return {
            "episodes": 0,
            "completion_rate": None,
            "mean_progress": None,
            "best_progress": None,
            "best_lap_time": None,
        }
    complete = _complete(train)
    laps = train["lap_time"].where(complete).dropna()
    return {
        "episodes": len(train),
        "completion_rate": float(complete.mean() * 100.0),
        "mean_progress": float(train["progress"].mean()),
        "best_progress": float(train["progress"].max()),
        "best_lap_time": float(laps.min()) if len(laps) else None,
    }


def as_records(table: pd.DataFrame) -> list[dict[str, float | int | None]]:
    """The table as JSON-friendly dicts (NaN -> ``None``)."""
    out = []
    for row in table.to_dict(orient="records"):
        out.append({k: (None if isinstance(v, float) and not np.isfinite(v) else v) for k, v in row.items()})
    return out
