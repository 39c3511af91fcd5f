"""A picture of the theoretical best lap: the racing line over the track, coloured by speed."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from drx.evaluate.theoretical_lap import BestLap
from drx.sim.track import Track


def draw_best_lap(track: Track, best: BestLap, path: str | Path, dpi: int = 120) -> Path:
    """Write a PNG of ``best``'s racing line on ``track``.

    The road is grey between its borders, the centre line dashed white, the
    racing line coloured by the speed profile (slow = dark, fast = bright),
    the start line marked and the braking points (where the speed falls)
    visible as the colour changes.

    :param track: the track.
    :param best: the best lap computed on it.
    :param path: the PNG file to write.
    :param dpi: resolution.
    :return: the path written.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import LineCollection
    from matplotlib.lines import Line2D

    out = Path(path)
    x0, y0, x1, y1 = _bounds(track)
    width = max(x1 - x0, 1e-3)
    height = max(y1 - y0, 1e-3)
    fig_w = 10.0
    fig, ax = plt.subplots(figsize=(fig_w, max(3.0, fig_w * height / width * 0.85 + 1.2)))
    ax.set_facecolor("#2e7d32")
    if track.closed:  # a loop: the outer polygon is road, the inner one grass again
        ax.fill(track.outer[:, 0], track.outer[:, 1], color="#555555", zorder=1)
        ax.fill(track.inner[:, 0], track.inner[:, 1], color="#2e7d32", zorder=1)
    else:
        road = np.vstack([track.outer, track.inner[::-1]])
        ax.fill(road[:, 0], road[:, 1], color="#555555", zorder=1)
    for border in (track.inner, track.outer):
        ax.plot(border[:, 0], border[:, 1], color="white", lw=1.2, zorder=2)
    ax.plot(
        track.center[:, 0], track.center[:, 1], color="white", lw=0.6, ls=(0, (4, 4)), alpha=0.6, zorder=2
    )
    ax.plot(
        [track.inner[0, 0], track.outer[0, 0]],
        [track.inner[0, 1], track.outer[0, 1]],
        color="white",
        lw=3,
        zorder=3,
    )
    pts = best.line.points
    if best.line.closed:
        pts = np.vstack([pts, pts[:1]])
        speeds = np.append(best.speeds, best.speeds[0])
    else:
        speeds = best.speeds
    segments = list(np.stack([pts[:-1], pts[1:]], axis=1))  # one (2, 2) array per piece of the line
    lc = LineCollection(segments, cmap="plasma", linewidths=2.5, zorder=4)
    lc.set_array(0.5 * (speeds[:-1] + speeds[1:]))
    # The colours span this car's own speeds once it is under way: the start from rest (clipped to
    # the darkest colour, the bar's arrow) would otherwise squeeze the whole lap into one colour.
    lo, hi = _colour_range(np.asarray(best.speeds))
    lc.set_clim(lo, hi)
    ax.add_collection(lc)
    extend = "min" if lo > float(np.min(speeds)) else "neither"
    fig.colorbar(lc, ax=ax, label="speed on the racing line [m/s]", shrink=0.8, extend=extend)
    handles = [
        Line2D([], [], color=plt.get_cmap("plasma")(0.85), lw=2.5, label="racing line (colour = speed)"),
        Line2D([], [], color="white", lw=0.8, ls=(0, (4, 4)), label="centre line"),
        Line2D([], [], color="white", lw=3, label="start line"),
    ]
    handles[1].set_color("#555555")  # drawn below the axes, on white
    handles[2].set_color("#333333")
    ax.legend(handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.12), ncols=3, fontsize=9,
              frameon=False)  # fmt: skip
    ax.set_aspect("equal")
    ax.set_xlim(x0 - 0.3, x1 + 0.3)
    ax.set_ylim(y0 - 0.3, y1 + 0.3)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    kind = "from rest"
    ax.set_title(
        f"{best.track_name} · car {best.car_name}: best lap {best.lap_time:.3f} s ({kind}), "
        f"line {best.line.length:.2f} m, {best.speeds.min():.2f}-{best.speeds.max():.2f} m/s"
        + ("" if best.line.length_weight == 0 else f"\n{best.line_kind}")
    )
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=dpi)
    plt.close(fig)
    return out


def _colour_range(speeds: np.ndarray) -> tuple[float, float]:
    """The speeds [m/s] the colour bar spans: from the slowest point after the launch (once the car
    first reaches 90% of its top speed on the lap) to the fastest, at least 5% of it wide."""
    hi = float(np.max(speeds))
    under_way = speeds[int(np.argmax(speeds >= 0.9 * hi)) :]
    lo = float(np.min(under_way))
    return min(lo, hi * 0.95), max(hi, 1e-3)


def _bounds(track: Track) -> tuple[float, float, float, float]:
    pts = np.vstack([track.inner, track.outer])
    return float(pts[:, 0].min()), float(pts[:, 1].min()), float(pts[:, 0].max()), float(pts[:, 1].max())
