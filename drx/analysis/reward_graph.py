"""``drx plot``: the DeepRacer console's reward graph, for one model or several.

Two panels share the iteration axis:

- top: reward per training episode (dots) and its average per iteration (line), with the
  evaluation episodes' average reward (dashed);
- bottom: progress [%] per training episode (dots) and its average per iteration (line),
  with the evaluation episodes (hollow dots) and their average (dashed).

The best checkpoint is a star on both panels. Each model has its own colour, so a
clone and its parent can be compared on one chart (a clone's iterations count from
its own start). A model that trains on several tracks has a training line per track (its
episodes on that track, averaged per iteration; each track its own line style), not one line
over tracks of different lengths and shapes; its evaluation drives its first track.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from drx.analysis.data import ModelRun
from drx.errors import DrxError, check_png

COLORS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#17becf", "#8c564b", "#e377c2")
JITTER = 0.35  # episodes of one iteration spread over ±this much of the x axis
TRACK_STYLES = ("-o", "-.^", ":D", "-v", "-.s", ":P")  # a several-track model's line per track


def _spread(df: pd.DataFrame) -> np.ndarray:
    """x positions of episodes: their iteration, spread evenly by episode index within it."""
    if df.empty:
        return np.zeros(0)
    n = df.groupby("iteration")["episode"].transform("count").to_numpy(float)
    k = df.groupby("iteration").cumcount().to_numpy(float)
    offset = np.where(n > 1, (k / np.maximum(n - 1, 1) - 0.5) * 2 * JITTER, 0.0)
    return df["iteration"].to_numpy(float) + offset


def _averages(df: pd.DataFrame, column: str) -> pd.Series:
    return df.groupby("iteration")[column].mean()


def _draw_run(run: ModelRun, color: str, ax_reward: Axes, ax_progress: Axes, label_prefix: str) -> None:
    train, evals = run.phase("training"), run.phase("evaluation")
    name = label_prefix
    tracks = run.training_tracks()
    if not train.empty:
        x = _spread(train)
        ax_reward.scatter(x, train["reward"], s=9, color=color, alpha=0.35, linewidths=0)
        ax_progress.scatter(x, train["progress"], s=9, color=color, alpha=0.35, linewidths=0)
        # one line per track when the model trains on several (each track's figures apart)
        lines = [(f"{name} training", train, "-o")] if len(tracks) < 2 else [
            (f"{name} training on {t}", train[train["track_name"] == t], TRACK_STYLES[i % len(TRACK_STYLES)])
            for i, t in enumerate(tracks)
        ]  # fmt: skip
        for label, part, style in lines:
            r = _averages(part, "reward")
            ax_reward.plot(r.index, r.values, style, color=color, ms=3, lw=1.8, label=label)
            p = _averages(part, "progress")
            ax_progress.plot(p.index, p.values, style, color=color, ms=3, lw=1.8, label=label)
    # the trainer's evaluation drives the first track
    evaluation = f"{name} evaluation" + (f" on {run.model.track_name}" if len(tracks) > 1 else "")
    if not evals.empty:
        r = _averages(evals, "reward")
        ax_reward.plot(
            r.index, r.values, "--s", color=color, ms=3, lw=1.2, alpha=0.9, label=evaluation
        )
        ax_progress.scatter(
            _spread(evals),
            evals["progress"],
            s=14,
            facecolors="none",
            edgecolors=color,
            alpha=0.6,
            linewidths=0.8,
        )
        p = _averages(evals, "progress")
        ax_progress.plot(
            p.index, p.values, "--s", color=color, ms=3, lw=1.2, alpha=0.9, label=evaluation
        )
    best = run.best_iteration
    if best is not None:
        source = evals if not evals.empty else train
        at = source[source["iteration"] == best]
        # the legend entry once, on the progress panel
        star_label = {"progress": f"{name} best checkpoint (iteration {best})", "reward": None}
        for ax, column in ((ax_progress, "progress"), (ax_reward, "reward")):
            if not at.empty:
                ax.scatter(
                    [best],
                    [at[column].mean()],
                    marker="*",
                    s=260,
                    color=color,
                    edgecolors="black",
                    linewidths=0.8,
                    zorder=5,
                    label=star_label[column],
                )
            ax.axvline(best, color=color, lw=0.8, ls=":", alpha=0.8)


def _iterations(run: ModelRun) -> list[int]:
    """The iterations a run has training episodes in, in order."""
    train = run.phase("training")
    return [] if train.empty else sorted(int(i) for i in train["iteration"].unique())


def _describe(run: ModelRun) -> str:
    """A model's line in the subtitle: track and algorithm, and how much there is to draw."""
    if run.episodes.empty:
        return f"{run.name}: no episodes yet, nothing drawn"
    n = len(_iterations(run))
    so_far = f"{n} iteration{'s' if n != 1 else ''}" + (" so far (lines need two)" if n == 1 else "")
    tracks = run.training_tracks()
    where = ", ".join(tracks) if len(tracks) > 1 else run.model.track_name
    return f"{run.name}: {where}, {run.model.algorithm.upper()}, {so_far}"


def reward_graph(runs: list[ModelRun], size: tuple[float, float] = (13.0, 7.5), dpi: int = 110) -> Figure:
    """The reward graph of one or more models.

    :param runs: the models' histories (:func:`drx.analysis.data.load_run`).
    :param size: figure size [inches].
    :param dpi: resolution of the saved PNG.
    :raises DrxError: no model has any episode yet.
    """
    if not runs:
        raise DrxError("Give at least one model to plot.")
    empty = [r.name for r in runs if r.episodes.empty]
    if len(empty) == len(runs):
        names = ", ".join(empty)
        raise DrxError(f"Model {names} has no episodes yet; train it first (`drx train {runs[0].name}`).")
    fig = Figure(figsize=size, dpi=dpi, layout="constrained")
    ax_reward, ax_progress = fig.subplots(2, 1, sharex=True)
    for i, run in enumerate(runs):
        _draw_run(run, COLORS[i % len(COLORS)], ax_reward, ax_progress, run.name)
    ax_reward.set_ylabel("reward per episode")
    ax_progress.set_ylabel("progress per episode [%]")
    ax_progress.set_xlabel("iteration")
    ax_progress.set_ylim(-3, 108)
    # whole iterations on the x axis, at least 0..1, so one iteration is not drawn on a -0.3..0.3 axis
    last = max((_iterations(r)[-1] for r in runs if _iterations(r)), default=0)
    ax_progress.set_xlim(-0.5, max(last, 1) + 0.5)
    for ax in (ax_reward, ax_progress):
        ax.grid(True, alpha=0.3)
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    handles, labels = ax_progress.get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside right upper", fontsize=8, frameon=False)
    title = runs[0].name if len(runs) == 1 else " vs ".join(r.name for r in runs)
    subtitle = "\n".join(_describe(r) for r in runs)
    fig.suptitle(f"Reward graph: {title}\n{subtitle}", fontsize=11)
    ax_reward.set_title(
        "dots: training episodes; lines: average per iteration; star: best checkpoint", fontsize=8
    )
    return fig


def save_reward_graph(runs: list[ModelRun], out: Path) -> Path:
    """Draw :func:`reward_graph` and write it as a PNG; return the path."""
    out = Path(out)
    check_png(out, "out")
    out.parent.mkdir(parents=True, exist_ok=True)
    reward_graph(runs).savefig(out)
    return out
