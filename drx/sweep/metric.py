"""What a sweep optimises: a figure of each iteration's evaluation, and its direction.

``progress`` (the evaluation episodes' mean lap progress, %) and ``reward`` (their mean
reward) are maximised; ``best-lap`` (the fastest complete evaluation lap, s) is minimised, and an
iteration without a complete lap scores ``+inf`` there. A trial's value is its best iteration's
figure, the iteration its model's best checkpoint comes from when the metric is progress or lap time.
"""

from __future__ import annotations

import math
from typing import Literal

from drx.errors import SettingError
from drx.train.records import IterationSummary

Direction = Literal["maximize", "minimize"]
METRICS: dict[str, Direction] = {"progress": "maximize", "reward": "maximize", "best-lap": "minimize"}


def check_metric(metric: str) -> str:
    """``metric`` if drx knows it.

    :raises DrxError: an unknown metric.
    """
    if metric not in METRICS:
        raise SettingError(
            "{field} {value} is unknown; use one of {allowed}.",
            "metric",
            value=metric,
            allowed=", ".join(METRICS),
        )
    return metric


def iteration_value(metric: str, summary: IterationSummary) -> float | None:
    """The iteration's figure for ``metric`` (``None`` when it had no evaluation)."""
    if metric == "best-lap":
        if not summary.eval_episodes:
            return None
        return summary.eval_best_lap_time if summary.eval_best_lap_time is not None else math.inf
    value = summary.eval_mean_progress if metric == "progress" else summary.eval_mean_reward
    return None if value is None else float(value)


def best_value(metric: str, values: list[float]) -> float | None:
    """The best of a trial's iteration figures (``None`` without any)."""
    if not values:
        return None
    return min(values) if METRICS[metric] == "minimize" else max(values)
