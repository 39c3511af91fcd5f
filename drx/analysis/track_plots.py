"""Pictures over the track from a trace: the best episodes' paths, reward and speed heat maps.

Everything is drawn in world metres with matplotlib on top of the road (grey, with its
borders and the dashed centre line), so every picture of one track lines up.
"""

from __future__ import annotations

import matplotlib
import numpy as np
import pandas as pd
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from drx.sim.track import Track

ROAD = "#b9b9b9"
BORDER = "#ffffff"
GROUND = "#f3f1ea"


def draw_track(ax: Axes, track: Track, start_marker: bool = True) -> None:
    """Draw the road, its borders, the dashed centre line and the start line on ``ax``."""
    outer, inner = np.asarray(track.outer), np.asarray(track.inner)
    ring = np.vstack([outer, inner[::-1]])
    ax.set_facecolor(GROUND)
    ax.fill(ring[:, 0], ring[:, 1], color=ROAD, lw=0, zorder=0)
    if track.closed:  # the ring's seam leaves the inner area road-coloured in some fills: clear it
        ax.fill(inner[:, 0], inner[:, 1], color=GROUND, lw=0, zorder=0)
    for border in (outer, inner):
        ax.plot(border[:, 0], border[:, 1], color=BORDER, lw=1.2, zorder=1)
    center = np.asarray(track.center)
    ax.plot(center[:, 0], center[:, 1], color="#fdfdfd", lw=0.6, ls=(0, (4, 4)), zorder=1)
    if start_marker:
        ax.plot([inner[0, 0], outer[0, 0]], [inner[0, 1], outer[0, 1]], color="black", lw=2.0, zorder=2)
    ax.set_aspect("equal")
    pad = 0.3
    lo = np.minimum(outer.min(axis=0), inner.min(axis=0)) - pad
    hi = np.maximum(outer.max(axis=0), inner.max(axis=0)) + pad
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")


def _figure_for(track: Track, panels: int = 1, width: float = 9.0) -> tuple[Figure, list[Axes]]:
    xs = np.concatenate([track.outer[:, 0], track.inner[:, 0]])
    ys = np.concatenate([track.outer[:, 1], track.inner[:, 1]])
    aspect = float(np.ptp(ys) + 0.6) / max(float(np.ptp(xs) + 0.6), 1e-3)
    height = min(max(width / panels * aspect + 1.2, 3.5), 9.0)
    fig = Figure(figsize=(width, height), dpi=110, layout="constrained")
    axes = fig.subplots(1, panels, squeeze=False)[0]
    return fig, list(axes)


def best_episodes(episodes: pd.DataFrame, count: int = 5) -> pd.DataFrame:
    """The ``count`` best episodes: most progress first, then fewest steps (the fastest lap)."""
    if episodes.empty:
        return episodes
    return episodes.sort_values(["progress", "steps"], ascending=[False, True]).head(count)


def paths_figure(track: Track, trace: pd.DataFrame, episodes: pd.DataFrame, title: str) -> Figure:
    """The paths of the given episodes (rows of :func:`drx.analysis.data.episode_table`) over the track.

    :param trace: the steps (``x``, ``y``, ``iteration``, ``episode``).
    :param episodes: which episodes to draw, best first.
    """
    fig, (ax,) = _figure_for(track)
    draw_track(ax, track)
    cmap = matplotlib.colormaps["tab10"]
    for k, (_, ep) in enumerate(episodes.iterrows()):
        steps = trace[(trace["iteration"] == ep["iteration"]) & (trace["episode"] == ep["episode"])]
        steps = steps.sort_values("steps")
        lap = f", {ep['lap_time']:.2f} s" if pd.notna(ep.get("lap_time")) else ""
        label = (
            f"iteration {int(ep['iteration'])}, episode {int(ep['episode'])}: "
            f"{ep['progress']:.0f}%, {int(ep['steps'])} steps{lap}"
        )
        color = cmap(k % 10)
        ax.plot(steps["x"], steps["y"], color=color, lw=1.6, alpha=0.9, label=label, zorder=3)
        ax.scatter(steps["x"].iloc[:1], steps["y"].iloc[:1], color=color, s=25, marker="o", zorder=4)
        ax.scatter(steps["x"].iloc[-1:], steps["y"].iloc[-1:], color=color, s=40, marker="x", zorder=4)
    if len(episodes):
        fig.legend(loc="outside lower center", fontsize=8, ncols=1 if len(episodes) < 4 else 2, frameon=False)
    ax.set_title(f"{title}: best episodes (o start, x end)", fontsize=10)
    return fig


def _gridsize(track: Track) -> int:
    span = max(float(np.ptp(track.outer[:, 0])), float(np.ptp(track.outer[:, 1])), 1.0)
    return int(np.clip(span / 0.12, 20, 120))  # hexagons about 12 cm across


def heatmap_figure(track: Track, trace: pd.DataFrame, title: str) -> Figure:
    """Two heat maps over the track: mean reward per step (left) and mean commanded speed (right)."""
    fig, axes = _figure_for(track, panels=2, width=13.0)
    size = _gridsize(track)
    for ax, column, label, cmap in (
        (axes[0], "reward", "mean reward per step", "viridis"),
        (axes[1], "speed", "mean speed [m/s]", "plasma"),
    ):
        draw_track(ax, track)
        data = trace.dropna(subset=["x", "y", column])
        if not data.empty:
            hb = ax.hexbin(
                data["x"],
                data["y"],
                C=data[column].astype(float),
                reduce_C_function=np.mean,
                gridsize=size,
                cmap=cmap,
                mincnt=1,
                linewidths=0,
                alpha=0.9,
                zorder=2,
            )
            fig.colorbar(hb, ax=ax, shrink=0.8, label=label)
        ax.set_title(f"{title}: {label}", fontsize=10)
    return fig
