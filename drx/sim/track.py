"""Track geometry read from DeepRacer's route format.

A route is an ``(N, 6)`` float array ``center_x, center_y, inner_x, inner_y,
outer_x, outer_y`` in metres, row 0 on the start line, rows in driving order,
closing duplicate row for loops (``../shared/tracks/README.md``).

Everything the reward ``params`` need per step is precomputed here once, so a
step costs a handful of scalar operations:

* centre-line segments as Python lists, for a projection that walks from last
  step's segment (the car moves at most a few segments per step; the NumPy
  search over all segments is the fallback);
* the local road width as a table over the centre-line distance ``s``,
  measured as DeepRacer does: distance between the inner-border point and the
  outer-border point nearest to the centre-line point;
* the road surface rasterised at 1 cm (outer polygon minus inner polygon, as
  DeepRacer's road polygon), for O(1) wheel-on-road tests.

highway-env's lanes (``CircularLane``/``SineLane``/``PolyLane``) are analytic
or assume perpendicular borders; DeepRacer routes are data with skewed
borders and repeated points, so this module is drx's own.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from drx.errors import DrxError, not_a_file
from drx.sim.geometry import (
    Corner,
    curvature_profile,
    find_corners,
    rasterise_road,
    signed_area,
    width_table,
)
from drx.sim.route import parse_route

RASTER_RESOLUTION = 0.01  # [m] road-mask pixel size
WIDTH_TABLE_STEP = 0.01  # [m] spacing of the width table along the centre line
WIDTH_SAMPLES = 400  # points along the line a track's median, least and greatest width are taken from


class Projection(NamedTuple):
    """A point projected onto the centre line.

    :param s: distance along the centre line from row 0 [m], in ``[0, length)`` for loops.
    :param prev_index: waypoint index just behind (DeepRacer's ``closest_waypoints[0]``).
    :param next_index: waypoint index just ahead (``closest_waypoints[1]``).
    :param distance: distance from the point to the centre line [m].
    :param left: the point is left of the centre line, seen in the driving direction.
    :param width: local road width at the projected point [m].
    :param foot_x: x of the projected point [m].
    :param foot_y: y of the projected point [m].
    :param segment: index of the centre-line segment holding the projected point (a hint for next time).
    """

    s: float
    prev_index: int
    next_index: int
    distance: float
    left: bool
    width: float
    foot_x: float
    foot_y: float
    segment: int


class _Tables(NamedTuple):
    """What a track precomputes once for its queries (lists where scalar hot paths index them)."""

    a_arr: np.ndarray  # (nseg, 2) segment starts
    d_arr: np.ndarray  # (nseg, 2) segment vectors
    inv_arr: np.ndarray  # 1 / squared segment length (0 for a repeated point)
    cum_arr: np.ndarray  # distance along the line of every waypoint [m]
    nseg: int
    length: float
    ax: list[float]
    ay: list[float]
    dx: list[float]
    dy: list[float]
    inv: list[float]
    seglen: list[float]
    cum: list[float]
    waypoints: list[tuple[float, float]]
    nondegenerate: np.ndarray  # each segment's nearest real (non-zero-length) segment
    seg_heading: np.ndarray  # [rad]
    width: list[float]  # road width every WIDTH_TABLE_STEP along the line [m]
    trust2: float  # walked projections farther than this (a road width, squared) are re-checked
    mask: np.ndarray  # uint8 road raster
    x0: float
    y0: float
    raster: tuple[float, float, float, int, int, bytes]  # x0, y0, 1/res, width, height, mask bytes


def _precompute(name: str, center: np.ndarray, inner: np.ndarray, outer: np.ndarray, closed: bool) -> _Tables:
    a = center[:-1]
    d = center[1:] - a
    seglen = np.hypot(d[:, 0], d[:, 1])
    inv = np.divide(1.0, seglen**2, out=np.zeros_like(seglen), where=seglen > 1e-12)
    cum = np.concatenate([[0.0], np.cumsum(seglen)])
    if cum[-1] <= 0:
        raise DrxError(f"Track {name!r} has a zero-length centre line.")
    # Zero-length segments take the heading of the next real one.
    good = np.flatnonzero(seglen > 1e-12)
    nondegenerate = good[np.clip(np.searchsorted(good, np.arange(len(a))), 0, len(good) - 1)]
    widths = width_table(center, cum, inner, outer, WIDTH_TABLE_STEP)
    mask, x0, y0 = rasterise_road(inner, outer, closed, RASTER_RESOLUTION)
    return _Tables(
        a_arr=a, d_arr=d, inv_arr=inv, cum_arr=cum, nseg=len(a), length=float(cum[-1]),
        ax=a[:, 0].tolist(), ay=a[:, 1].tolist(), dx=d[:, 0].tolist(), dy=d[:, 1].tolist(),
        inv=inv.tolist(), seglen=seglen.tolist(), cum=cum.tolist(),
        waypoints=[(float(px), float(py)) for px, py in center],
        nondegenerate=nondegenerate, seg_heading=np.arctan2(d[:, 1], d[:, 0]),
        width=widths.tolist(), trust2=float(widths.max()) ** 2,
        mask=mask, x0=x0, y0=y0,
        raster=(x0, y0, 1.0 / RASTER_RESOLUTION, mask.shape[1], mask.shape[0], mask.tobytes()),
    )  # fmt: skip


@dataclass(frozen=True, eq=False)
class Track:
    """A track: centre line and borders in driving order.

    :param name: the track's name (file stem).
    :param center: ``(N, 2)`` centre-line waypoints [m]; for loops the last row repeats the first.
    :param inner: ``(N, 2)`` geometric inside border [m].
    :param outer: ``(N, 2)`` geometric outside border [m].
    :param closed: whether the track is a loop.
    :param notes: what :meth:`from_route` fixed or noticed while reading the route.
    """

    name: str
    center: np.ndarray
    inner: np.ndarray
    outer: np.ndarray
    closed: bool = True
    notes: tuple[str, ...] = ()
    _tables: _Tables = field(init=False, repr=False)

    def __post_init__(self) -> None:
        for key in ("center", "inner", "outer"):
            arr = np.ascontiguousarray(np.asarray(getattr(self, key), dtype=np.float64))
            if arr.ndim != 2 or arr.shape[1] != 2 or len(arr) < 2:
                raise DrxError(f"Track {self.name!r}: {key} must be an (N, 2) array of at least 2 points.")
            arr.setflags(write=False)
            object.__setattr__(self, key, arr)
        if not len(self.center) == len(self.inner) == len(self.outer):
            raise DrxError(f"Track {self.name!r}: centre and borders need the same number of rows.")
        tables = _precompute(self.name, self.center, self.inner, self.outer, self.closed)
        object.__setattr__(self, "_tables", tables)

    # ----- construction --------------------------------------------------
    @classmethod
    def from_route(cls, route: Any, name: str = "track") -> tuple[Track, list[str]]:
        """Read DeepRacer's ``(N, 6)`` route array and fix its quirks.

        Fixes: a nearly closed loop gets its closing row; swapped inner/outer
        borders are put back. Repeated centre points are kept (so waypoint
        indices match DeepRacer's) and their zero-length segments are skipped.
        :return: the track and notes saying what was fixed.
        :raises DrxError: on a malformed array.
        """
        center, inner, outer, closed, notes = parse_route(route, name)
        return cls(
            name=name, center=center, inner=inner, outer=outer, closed=closed, notes=tuple(notes)
        ), notes

    def to_route(self) -> np.ndarray:
        """The track as DeepRacer's ``(N, 6)`` route array."""
        return np.hstack([self.center, self.inner, self.outer])

    def reversed(self) -> Track:
        """The same road driven the other way (inner stays the geometric inside)."""
        return Track(
            name=f"{self.name}_reversed" if not self.name.endswith("_reversed") else self.name[:-9],
            center=self.center[::-1].copy(),
            inner=self.inner[::-1].copy(),
            outer=self.outer[::-1].copy(),
            closed=self.closed,
            notes=self.notes,
        )

    # ----- facts ---------------------------------------------------------
    @property
    def length(self) -> float:
        """Centre-line length [m]."""
        return self._tables.length

    @property
    def direction(self) -> str:
        """``"ccw"`` or ``"cw"`` for loops, ``"-"`` for open tracks."""
        if not self.closed:
            return "-"
        return "ccw" if signed_area(self.center[:-1]) > 0 else "cw"

    @property
    def waypoints(self) -> list[tuple[float, float]]:
        """Centre-line points as DeepRacer's ``params["waypoints"]`` (a cached list: do not mutate)."""
        return self._tables.waypoints

    @property
    def cumulative(self) -> np.ndarray:
        """Distance along the centre line of every waypoint [m] (``(N,)``)."""
        return self._tables.cum_arr

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """``(xmin, ymin, xmax, ymax)`` of the borders [m]."""
        pts = np.vstack([self.inner, self.outer, self.center])
        return (
            float(pts[:, 0].min()),
            float(pts[:, 1].min()),
            float(pts[:, 0].max()),
            float(pts[:, 1].max()),
        )

    # ----- queries -------------------------------------------------------
    def project(self, x: float, y: float, hint: int | None = None) -> Projection:
        """Project a point onto the centre line.

        :param x: point x [m].
        :param y: point y [m].
        :param hint: the segment of the last projection; walks from it along the line while the
            distance shrinks (falls back to the whole line when the result lies farther than a
            road width, e.g. after a jump).
        """
        c = self._tables
        if hint is None:
            i, t = self._project_global(x, y)
        else:
            i, t, best = self._descend(x, y, hint)
            if best > c.trust2:  # farther than a road width: maybe nearer another part of the track
                i, t = self._project_global(x, y)
        cum, seglen = c.cum, c.seglen
        if 0.0 < t < 1.0:  # inside a real segment: the waypoints are its ends (no bisect needed)
            s = cum[i] + t * seglen[i]
            return self._projection(x, y, i, t, s, i, i + 1)
        s = cum[i] + t * seglen[i]
        if self.closed and s >= c.length:
            s -= c.length
        prev_i, next_i = self._prev_next(s)
        return self._projection(x, y, i, t, s, prev_i, next_i)

    def _descend(self, x: float, y: float, hint: int) -> tuple[int, float, float]:
        """Walk from segment ``hint`` along the line while the distance does not grow.

        The car moves a few segments per step, so this checks 2-4 segments instead of all.
        :return: ``(segment, t, squared distance)``.
        """
        c = self._tables
        ax, ay, dx, dy, inv = c.ax, c.ay, c.dx, c.dy, c.inv
        nseg, closed = c.nseg, self.closed

        def dist2(j: int) -> tuple[float, float]:
            rx, ry = x - ax[j], y - ay[j]
            tt = (rx * dx[j] + ry * dy[j]) * inv[j]
            tt = 0.0 if tt < 0.0 else (1.0 if tt > 1.0 else tt)
            ex, ey = rx - tt * dx[j], ry - tt * dy[j]
            return ex * ex + ey * ey, tt

        i = hint % nseg
        best, t = dist2(i)
        for step in (1, -1):
            moved, j = False, i
            for _ in range(nseg):
                j += step
                if closed:
                    j %= nseg
                elif j < 0 or j >= nseg:
                    break
                if inv[j] == 0.0:  # a repeated point: its zero-length segment is skipped
                    continue
                d2, tt = dist2(j)
                if d2 >= best:
                    break
                best, i, t, moved = d2, j, tt, True
            if moved:
                break
        return i, t, best

    def _project_global(self, x: float, y: float) -> tuple[int, float]:
        c = self._tables
        a, d, inv = c.a_arr, c.d_arr, c.inv_arr
        rx, ry = x - a[:, 0], y - a[:, 1]
        t = np.clip((rx * d[:, 0] + ry * d[:, 1]) * inv, 0.0, 1.0)
        ex, ey = rx - t * d[:, 0], ry - t * d[:, 1]
        i = int(np.argmin(ex * ex + ey * ey))
        return i, float(t[i])

    def _projection(
        self, x: float, y: float, i: int, t: float, s: float, prev_i: int, next_i: int
    ) -> Projection:
        c = self._tables
        ax, ay, dx, dy = c.ax[i], c.ay[i], c.dx[i], c.dy[i]
        fx, fy = ax + t * dx, ay + t * dy
        cross = dx * (y - ay) - dy * (x - ax)
        return Projection(
            s, prev_i, next_i, math.hypot(x - fx, y - fy), cross > 0.0, self.width_at(s), fx, fy, i
        )

    def _prev_next(self, s: float) -> tuple[int, int]:
        # DeepRacer's find_prev_next: bisect_right over the waypoints' distances along the line,
        # wrapping "next" to 0 past the last one (only reached at the far end of an open track).
        cum = self._tables.cum
        nxt = bisect.bisect_right(cum, s)
        if nxt >= len(cum):
            return len(cum) - 1, 0
        return max(nxt - 1, 0), nxt

    def width_at(self, s: float) -> float:
        """Local road width [m] at distance ``s`` along the centre line."""
        table = self._tables.width
        u = s / WIDTH_TABLE_STEP
        k = int(u)
        if k < 0:
            return table[0]
        if k >= len(table) - 1:
            return table[-1]
        f = u - k
        return table[k] * (1.0 - f) + table[k + 1] * f

    def point_at(self, s: Any) -> np.ndarray:
        """Centre-line point(s) at distance ``s`` [m] (wraps on loops); ``(2,)`` or ``(k, 2)``."""
        s = self._wrap_s(np.asarray(s, dtype=np.float64))
        cum = self._tables.cum_arr
        return np.stack([np.interp(s, cum, self.center[:, 0]), np.interp(s, cum, self.center[:, 1])], axis=-1)

    def heading_at(self, s: Any) -> Any:
        """Direction [rad] of the centre line at distance ``s`` [m]."""
        s = self._wrap_s(np.asarray(s, dtype=np.float64))
        seg = np.clip(np.searchsorted(self._tables.cum_arr, s, side="right") - 1, 0, self._tables.nseg - 1)
        seg = self._tables.nondegenerate[seg]
        h = self._tables.seg_heading[seg]
        return float(h) if np.ndim(h) == 0 else h

    def _wrap_s(self, s: np.ndarray) -> np.ndarray:
        return np.mod(s, self.length) if self.closed else np.clip(s, 0.0, self.length)

    def on_road(self, points: Any) -> np.ndarray:
        """Whether each point of a ``(k, 2)`` array lies on the road surface (1 cm raster)."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        c = self._tables
        ix = np.floor((p[:, 0] - c.x0) / RASTER_RESOLUTION + 0.5).astype(np.int64)
        iy = np.floor((p[:, 1] - c.y0) / RASTER_RESOLUTION + 0.5).astype(np.int64)
        h, w = c.mask.shape
        inside = (ix >= 0) & (ix < w) & (iy >= 0) & (iy < h)
        out = np.zeros(len(p), dtype=bool)
        out[inside] = c.mask[iy[inside], ix[inside]] > 0
        return out

    def on_road_xy(self, x: float, y: float) -> bool:
        """Scalar :meth:`on_road` for one point."""
        return self.on_road_points(((x, y),))[0]

    def on_road_points(self, points: Any) -> list[bool]:
        """:meth:`on_road` for a few ``(x, y)`` tuples (the per-wheel hot path, no NumPy calls)."""
        x0, y0, inv, w, h, mask = self._tables.raster
        out = []
        for x, y in points:
            u, v = (x - x0) * inv + 0.5, (y - y0) * inv + 0.5
            if u < 0.0 or v < 0.0:
                out.append(False)
                continue
            ix, iy = int(u), int(v)
            out.append(ix < w and iy < h and mask[iy * w + ix] != 0)
        return out

    @property
    def road_mask(self) -> tuple[np.ndarray, float, float, float]:
        """``(mask, x0, y0, resolution)``: uint8 road raster; pixel ``[iy, ix]`` is centred at
        ``(x0 + ix * res, y0 + iy * res)``."""
        c = self._tables
        return c.mask, c.x0, c.y0, RASTER_RESOLUTION

    # ----- shape summary -------------------------------------------------
    def curvature(self, step: float = 0.05, window: float = 0.25) -> tuple[np.ndarray, np.ndarray]:
        """Signed curvature [1/m, + = left] sampled every ``step`` m, smoothed over ``±window`` m.

        :return: ``(s, kappa)`` arrays.
        """
        return curvature_profile(self.heading_at, self.length, self.closed, step, window)

    def corners(self, min_angle_deg: float = 30.0, max_radius: float = 3.0) -> list[Corner]:
        """The track's corners: runs of curvature tighter than ``max_radius`` [m] that turn at
        least ``min_angle_deg``, in driving order (``len(corners())`` is the turn count)."""
        step = 0.05
        s, k = self.curvature(step)
        return find_corners(s, k, step, self.closed, min_angle_deg, max_radius)


def load_track(name_or_path: str | Path) -> Track:
    """Load a track from a ``.npy`` path, or by name: a shipped track (DeepRacer's route id or
    display name, drx's own) or one imported into ``$DRX_HOME/tracks`` (:mod:`drx.sim.catalogue`).

    :raises NotFoundError: when no such track exists (the sentence gives near matches).
    """
    from drx.config import data_home
    from drx.sim.catalogue import imported_files, resolve, shipped_tracks

    text = str(name_or_path)
    path = Path(text).expanduser()
    if text.endswith(".npy") or path.is_file():
        if not path.is_file():
            raise not_a_file(text, "Track file", "give a DeepRacer route .npy file")
        return _read(path)
    entry = resolve(text, [*shipped_tracks(), *imported_files(data_home() / "tracks")])
    return _read(entry.path)


def route_facts(path: Path) -> dict[str, Any]:
    """A route's length, widths and direction as :class:`Track` measures them, without building
    the track (its 1 cm road raster is most of the 0.01-0.5 s a track takes to load): what
    ``drx track list`` shows.

    :return: ``length`` [m], ``width`` (median), ``width_min``, ``width_max`` [m], ``direction``,
        ``closed``, ``n_waypoints``.
    """
    from drx.sim.route import read_route_file

    center, inner, outer, closed, _ = parse_route(read_route_file(path), path.stem)
    seglen = np.hypot(*np.diff(center, axis=0).T)
    cum = np.concatenate([[0.0], np.cumsum(seglen)])
    table = width_table(center, cum, inner, outer, WIDTH_TABLE_STEP)
    u = np.linspace(0.0, float(cum[-1]), WIDTH_SAMPLES, endpoint=False) / WIDTH_TABLE_STEP
    widths = np.interp(u, np.arange(len(table)), table)  # Track.width_at, vectorised
    direction = "-" if not closed else ("ccw" if signed_area(center[:-1]) > 0 else "cw")
    return {
        "length": float(cum[-1]),
        "width": float(np.median(widths)),
        "width_min": float(widths.min()),
        "width_max": float(widths.max()),
        "direction": direction,
        "closed": bool(closed),
        "n_waypoints": len(center),
    }


def _read(path: Path) -> Track:
    from drx.sim.route import read_route_file

    track, _ = Track.from_route(read_route_file(path), name=path.stem)
    return track
