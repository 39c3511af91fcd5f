"""Action breakdown per track section: which actions the car chooses in each turn and straight.

Sections come from the track's geometry: every corner (:meth:`Track.corners`) is a
section, and so is every straight between two corners. A step belongs to the section
holding its ``closest_waypoint``'s distance along the centre line. A track without
corners is cut into four equal sections.

Discrete cars count action indices. Continuous cars' actions are binned: steering into
seven bins over the car's range, speed into three, so the same bar chart reads both.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import matplotlib
import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from drx.analysis.track_plots import draw_track
from drx.sim.track import Track
from drx.vehicle import Vehicle

STEER_BINS = 7
SPEED_BINS = 3
MERGE_GAP = 0.5  # [m] bends of one direction closer than this (or MERGE_FRACTION of the lap) are one section
MERGE_FRACTION = 0.03


@dataclass(frozen=True)
class Section:
    """A stretch of the track.

    :param index: 1-based, in driving order from the start line.
    :param start_s: where it starts [m along the centre line].
    :param end_s: where it ends [m] (``end_s < start_s`` when it wraps past the start line).
    :param kind: ``left turn``, ``right turn`` or ``straight``.
    """

    index: int
    start_s: float
    end_s: float
    kind: str

    @property
    def label(self) -> str:
        """E.g. ``S2 left turn``."""
        return f"S{self.index} {self.kind}"

    def contains(self, s: np.ndarray, length: float) -> np.ndarray:
        """Which of the distances ``s`` [m] fall in this section."""
        if self.end_s >= self.start_s:
            return (s >= self.start_s) & (s < self.end_s)
        return (s >= self.start_s) | (s < self.end_s)  # wraps around the start line


def track_sections(track: Track) -> list[Section]:
    """The track cut into corners and the straights between them, in driving order."""
    length = float(track.length)
    corners = sorted(track.corners(), key=lambda c: c.start_s)
    if not corners:
        q = length / 4
        return [Section(i + 1, i * q, (i + 1) * q, "straight") for i in range(4)]
    cuts: list[tuple[float, float, str]] = []
    merge_gap = max(MERGE_GAP, MERGE_FRACTION * length)
    for c in corners:
        a, b = float(c.start_s) % length, float(c.end_s) % length
        kind = "left turn" if c.angle_deg > 0 else "right turn"
        if cuts and cuts[-1][2] == kind and (a - cuts[-1][1]) % length < merge_gap:
            cuts[-1] = (cuts[-1][0], b, kind)  # one bend that the curvature split in two
        else:
            cuts.append((a, b, kind))
    if (
        track.closed
        and len(cuts) > 1
        and cuts[0][2] == cuts[-1][2]
        and (cuts[0][0] - cuts[-1][1]) % length < merge_gap
    ):
        cuts[0] = (cuts[-1][0], cuts[0][1], cuts[0][2])
        cuts.pop()
    pieces: list[tuple[float, float, str]] = []
    for k, (a, b, kind) in enumerate(cuts):
        pieces.append((a, b, kind))
        nxt = cuts[(k + 1) % len(cuts)][0] if (track.closed or k + 1 < len(cuts)) else length
        gap = (nxt - b) % length if track.closed else nxt - b
        if gap >= merge_gap:
            pieces.append((b, nxt, "straight"))
        elif gap > 0:
            pieces[-1] = (a, nxt, kind)  # a short gap between two bends joins the first
    first = cuts[0][0]
    if not track.closed and first > 0:
        pieces.insert(0, (0.0, first, "straight"))
    # Start the numbering with the section that holds the start line.
    start = next(
        (i for i, p in enumerate(pieces) if Section(0, p[0], p[1], "").contains(np.array([0.0]), length)[0]),
        0,
    )
    pieces = pieces[start:] + pieces[:start]
    return [Section(i + 1, a, b, kind) for i, (a, b, kind) in enumerate(pieces)]


def step_distance(track: Track, trace: pd.DataFrame) -> np.ndarray:
    """Each step's distance along the centre line [m], from its ``closest_waypoint``."""
    cum = np.asarray(track.cumulative, float)
    idx = np.clip(trace["closest_waypoint"].to_numpy(int), 0, len(cum) - 1)
    return cum[idx] % max(float(track.length), 1e-9)


def action_labels(vehicle: Vehicle) -> list[str]:
    """Bar labels: ``#i steer°/speed`` for discrete cars, bin centres for continuous ones."""
    if not vehicle.continuous:
        return [f"#{i} {a.steering_angle:g}°/{a.speed:g}" for i, a in enumerate(vehicle.actions)]
    steer, speed = _bin_edges(vehicle)
    sc = (steer[:-1] + steer[1:]) / 2
    vc = (speed[:-1] + speed[1:]) / 2
    return [f"{s:+.0f}°/{v:.1f}" for s in sc for v in vc]


def _bin_edges(vehicle: Vehicle) -> tuple[np.ndarray, np.ndarray]:
    return (
        np.linspace(vehicle.steering_range[0], vehicle.steering_range[1], STEER_BINS + 1),
        np.linspace(vehicle.speed_range[0], vehicle.speed_range[1], SPEED_BINS + 1),
    )


def action_codes(vehicle: Vehicle, trace: pd.DataFrame) -> np.ndarray:
    """Each step's action as a bar index (see :func:`action_labels`); -1 when unknown."""
    if not vehicle.continuous:
        codes = pd.to_numeric(trace["action"], errors="coerce").fillna(-1).to_numpy(int)
        return np.where((codes >= 0) & (codes < vehicle.n_actions), codes, -1)
    steer_edges, speed_edges = _bin_edges(vehicle)
    si = np.clip(np.digitize(trace["steering_angle"].to_numpy(float), steer_edges[1:-1]), 0, STEER_BINS - 1)
    vi = np.clip(np.digitize(trace["speed"].to_numpy(float), speed_edges[1:-1]), 0, SPEED_BINS - 1)
    return si * SPEED_BINS + vi


def action_breakdown(track: Track, vehicle: Vehicle, trace: pd.DataFrame) -> pd.DataFrame:
    """Share of each action [%] per section: rows = section labels, columns = action labels."""
    sections = track_sections(track)
    labels = action_labels(vehicle)
    s = step_distance(track, trace)
    codes = action_codes(vehicle, trace)
    table = np.zeros((len(sections), len(labels)))
    for i, sec in enumerate(sections):
        c = codes[sec.contains(s, float(track.length)) & (codes >= 0)]
        if len(c):
            table[i] = np.bincount(c, minlength=len(labels))[: len(labels)] / len(c) * 100.0
    return pd.DataFrame(table, index=[sec.label for sec in sections], columns=labels)


def action_codes_short(vehicle: Vehicle) -> list[str]:
    """Short bar names that fit under a bar at a readable size: ``#i`` for a discrete car's
    actions, ``b i`` for a continuous car's bins; :func:`action_labels` says what each is."""
    prefix = "b" if vehicle.continuous else "#"
    return [f"{prefix}{i}" for i in range(len(action_labels(vehicle)))]


TICK_FONT = 9  # [pt] bar names under each section's chart
KEY_FONT = 10  # [pt] the key of what each bar name means


def breakdown_figure(track: Track, vehicle: Vehicle, trace: pd.DataFrame, title: str) -> Figure:
    """A map of the sections, the key of the actions, and one bar chart per section of the
    actions chosen there (bars named ``#i``, read in the key, so the names stay readable)."""
    sections = track_sections(track)
    table = action_breakdown(track, vehicle, trace)
    n = len(sections)
    cols = min(4, int(np.ceil(np.sqrt(n))))
    rows = int(np.ceil(n / cols))
    fig = Figure(figsize=(5.0 + 4.0 * cols, max(6.0, 3.0 * rows)), dpi=100, layout="constrained")
    grid_rows = max(rows, 2)  # the map above, the key of the bar names below it
    grid = fig.add_gridspec(grid_rows, cols + 2)
    ax_map = fig.add_subplot(grid[: grid_rows - 1, :2])
    draw_track(ax_map, track)
    cmap = matplotlib.colormaps["tab20"]
    s_all = np.linspace(0, float(track.length), 600, endpoint=False)
    pts = np.asarray(track.point_at(s_all))
    for k, sec in enumerate(sections):
        mask = sec.contains(s_all, float(track.length))
        ax_map.scatter(pts[mask, 0], pts[mask, 1], s=10, color=cmap(k % 20), zorder=3)
        mid = s_all[mask][len(s_all[mask]) // 2] if mask.any() else sec.start_s
        x, y = np.asarray(track.point_at(mid))
        ax_map.annotate(
            f"S{sec.index}",
            (x, y),
            fontsize=10,
            weight="bold",
            ha="center",
            va="center",
            zorder=4,
            bbox={"boxstyle": "round", "fc": "white", "ec": cmap(k % 20)},
        )
    ax_map.set_title(f"{title}: sections", fontsize=10)
    names = action_codes_short(vehicle)
    _draw_key(fig.add_subplot(grid[grid_rows - 1, :2]), names, list(table.columns), vehicle)
    x = np.arange(len(table.columns))
    top = min(100.0, max(10.0, float(table.to_numpy().max()) * 1.15))  # one scale for every section
    many = len(names) > 12
    for k, sec in enumerate(sections):
        ax = fig.add_subplot(grid[:, 2 + k] if rows == 1 else grid[k // cols, 2 + k % cols])
        ax.bar(x, table.iloc[k].to_numpy(), color=cmap(k % 20))
        ax.set_title(sec.label, fontsize=10)
        ax.set_ylim(0, top)
        ax.set_ylabel("% of steps", fontsize=9)
        ax.set_xticks(x, names, rotation=90 if many else 0, fontsize=TICK_FONT - (1 if many else 0))
        ax.tick_params(axis="y", labelsize=8)
        ax.grid(True, axis="y", alpha=0.3)
    legend = "steering/speed bins" if vehicle.continuous else "actions"
    fig.suptitle(f"{title}: {legend} per section", fontsize=12)
    return fig


def _draw_key(ax: Any, names: list[str], labels: list[str], vehicle: Vehicle) -> None:
    """The key under the map: each bar name and the action (steering°/speed m/s) it stands for."""
    what = "bin centre, steering°/speed m/s" if vehicle.continuous else "steering°/speed m/s"
    entries = [f"{n:>3} {label if vehicle.continuous else label.split(' ', 1)[-1]}"
               for n, label in zip(names, labels, strict=True)]  # fmt: skip
    n_columns = 3 if len(entries) > 10 else 2
    per_column = int(np.ceil(len(entries) / n_columns))
    ax.axis("off")
    ax.set_title(f"bars: {what}", fontsize=KEY_FONT, loc="left")
    for i in range(0, len(entries), per_column):
        text = "\n".join(entries[i : i + per_column])
        x = i // per_column / n_columns
        ax.text(x, 1.0, text, transform=ax.transAxes, fontsize=KEY_FONT, va="top", family="monospace")
