"""The minimum-curvature racing line inside a track's borders.

Method (the classic "minimum curvature" line of Braghin et al. 2008 and
Heilmeier et al. 2019, in its simplest discrete form):

1. **Reference line.** The centre line is resampled at a uniform spacing
   ``h`` (0.1 m; coarser on tracks longer than ``MAX_POINTS * h``) and
   lightly smoothed (Gaussian, 0.15 m) into points ``c_i`` with unit left
   normals ``n_i``.
2. **Corridor.** A candidate point is ``p_i = c_i + a_i n_i``. With ``d_L``
   and ``d_R`` the distances from ``c_i`` to the left and right borders
   (nearest point on each border polyline), the triangle inequality gives a
   clearance of at least ``d - |a_i|`` from that border, so the bounds
   ``-(d_R - w) <= a_i <= d_L - w`` keep the car's half-width ``w`` clear of
   both borders for any offset inside them (exact on straights, slightly
   cautious in bends; step 4 removes most of the caution).
3. **Quadratic program.** Curvature is approximated by the second
   difference ``(p_{i-1} - 2 p_i + p_{i+1}) / h^2`` of the uniformly spaced
   reference; its sum of squares is a convex quadratic ``1/2 a'Ha + g'a`` in
   the offsets. Minimising it in the box of step 2 is a box-constrained QP,
   solved exactly by :mod:`drx.evaluate.boxqp` (projected Newton, NumPy
   only). A tiny ridge keeps straights (where any parallel shift is equally
   straight) well posed: it picks the candidate nearest the reference.
4. **Re-linearisation.** The solution is resampled uniformly (points that
   the resampling chords pushed closer than ``w`` to a border, or across a
   sharp tip of one, are moved back onto the road, :func:`keep_clear`) and
   used as the next reference line, with new
   normals and a new corridor; step 3 is repeated, three solves in all.

``length_weight`` blends in a shortest-path term (Braghin et al. 2008): the
sum of squared first differences, scaled to the curvature term. A blend is a
shorter, more sharply bent line; :mod:`drx.evaluate.theoretical_lap` uses it for cars
that their top speed, not grip, holds back.

Loops are periodic (the second differences wrap around). On an open track
the line starts at the centre of the start line and may end anywhere across
the finish.

Known bias: the second difference measures curvature times the square of the
point spacing, and offsets towards the inside of a bend bring points closer
together, so the linearised objective leans slightly to the inside of long
constant-radius bends (on a circular road it picks the inner circle). That
line is also the faster one there (a grip-limited lap of a circle of radius
``r`` takes ``2 pi sqrt(r / a)``), which suits a lower bound on lap time.
The line minimises curvature, not time; the lap time of
:mod:`drx.evaluate.speed_profile` on it is the bound drx reports, and a
scripted driver following it in the simulator comes within a few percent
(``benchmarks/best_lap.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from drx.evaluate.boxqp import solve_box_qp

DEFAULT_SPACING = 0.1  # [m] distance between racing-line points
MAX_POINTS = 400  # longer tracks get a coarser spacing (the dense QP costs ~n^3)
DEFAULT_ITERATIONS = 3  # QP solves, each around the previous solution
SMOOTHING = 0.15  # [m] Gaussian smoothing of the centre line into the first reference line
RIDGE = 1e-6  # relative weight of sum(a^2): keeps straights well posed
CAP_ITERATIONS = 8  # reweighted solves at most for a line that bends tighter than the car can turn
OPEN_END = 0.5  # [m] an open track's borders drawn on past its ends, for inside_road


@dataclass(frozen=True)
class RacingLine:
    """A racing line through a track.

    :param points: ``(m, 2)`` points [m], in driving order; no closing duplicate on loops.
    :param closed: whether the line is a loop.
    :param curvature: ``(m,)`` signed curvature [1/m] at each point (+ = turning left).
    :param clearance: the smallest distance [m] from a line point to either border.
    :param half_width: the half-width [m] kept clear of the borders.
    :param length_weight: 0 for the minimum-curvature line, more for a blend towards the shortest path.
    """

    points: np.ndarray
    closed: bool
    curvature: np.ndarray
    clearance: float
    half_width: float
    length_weight: float = 0.0

    @property
    def segment_lengths(self) -> np.ndarray:
        """Lengths [m] from each point to the next (to the first again on loops)."""
        return segment_lengths(self.points, self.closed)

    @property
    def length(self) -> float:
        """Length [m] of the line (one lap)."""
        return float(np.sum(self.segment_lengths))

    def waypoints(
        self, count: int | None = None, borders: tuple[np.ndarray, np.ndarray] | None = None
    ) -> list[tuple[float, float]]:
        """The line as ``(x, y)`` tuples, loops with a closing duplicate like DeepRacer's waypoints.

        :param count: resample to this many distinct points first (default: as stored).
        :param borders: the track's two border polylines: resampled points that the chords pushed
            closer than ``half_width`` to one, or past it, are moved back (:func:`keep_clear`), as between
            the solves.
        """
        pts = self.points if count is None else resample(self.points, self.closed, count)
        if count is not None and borders is not None:
            pts = keep_clear(pts, borders, self.half_width, self.closed)
        if self.closed:
            pts = np.vstack([pts, pts[:1]])
        return [(float(x), float(y)) for x, y in pts]


def min_curvature_line(
    center: np.ndarray,
    inner: np.ndarray,
    outer: np.ndarray,
    closed: bool,
    half_width: float,
    *,
    spacing: float = DEFAULT_SPACING,
    iterations: int = DEFAULT_ITERATIONS,
    length_weight: float = 0.0,
    max_curvature: float | None = None,
) -> RacingLine:
    """Compute the minimum-curvature racing line (see the module docstring for the method).

    :param center: ``(n, 2)`` centre-line points in driving order (a closing duplicate is allowed).
    :param inner: ``(n, 2)`` inner border points.
    :param outer: ``(n, 2)`` outer border points.
    :param closed: whether the track is a loop.
    :param half_width: [m] the clearance to keep from both borders (the car's half-width, or less where
        the rules let wheels leave the road). Keep it positive: the corridor's bounds are distances to
        the borders, blind to which side of one a point is (at 0 the line crossed them by up to 8 cm in
        hairpins).
    :param spacing: [m] distance between the line's points.
    :param iterations: QP solves (each re-linearised around the previous line).
    :param length_weight: 0 for the minimum-curvature line; towards 1 the line blends into the
        shortest path (Braghin et al.'s compromise, see :func:`_solve_once`).
    :param max_curvature: [1/m] the tightest bend the car can turn. Where the line bends tighter (a
        hairpin the sum of squares concentrates into a few points), the curvature there is weighed more,
        by ``(|k| / max_curvature)^2`` again on each of up to :data:`CAP_ITERATIONS` more solves
        (iteratively reweighted least squares towards the smallest largest curvature), so the bend
        spreads over the road's width where the road allows it.
    :return: the racing line.
    """
    center = clean_polyline(np.asarray(center, dtype=float), closed)
    inner_b = border_polyline(np.asarray(inner, dtype=float), closed)
    outer_b = border_polyline(np.asarray(outer, dtype=float), closed)
    length = float(np.sum(segment_lengths(center, closed)))
    step = max(spacing, length / MAX_POINTS)
    count = max(8, round(length / step)) + (0 if closed else 1)
    ref = smooth(resample(center, closed, count), closed, SMOOTHING / (length / count))
    left_b, right_b = _left_right(ref, closed, inner_b, outer_b)
    for k in range(max(1, iterations)):
        if k:
            # uniform spacing again around the previous solution; resampling cuts chords across the
            # apexes, so push those few points back to the half-width first (keeps step 2's guarantee)
            ref = keep_clear(resample(ref, closed, count), (left_b, right_b), half_width, closed)
        ref = _solve_once(ref, closed, left_b, right_b, half_width, length_weight)
    if max_curvature is not None:
        weights = np.ones(len(ref))
        for _ in range(CAP_ITERATIONS):
            over = np.abs(curvature(ref, closed)) / max_curvature
            if over.max() <= 1.0:
                break
            weights *= np.maximum(over, 1.0) ** 2
            ref = keep_clear(resample(ref, closed, count), (left_b, right_b), half_width, closed)
            ref = _solve_once(ref, closed, left_b, right_b, half_width, length_weight, weights)
    clearance = float(
        min(np.min(distance_to_polyline(ref, left_b)), np.min(distance_to_polyline(ref, right_b)))
    )
    return RacingLine(
        points=ref,
        closed=closed,
        curvature=curvature(ref, closed),
        clearance=clearance,
        half_width=half_width,
        length_weight=length_weight,
    )


def _solve_once(
    ref: np.ndarray,
    closed: bool,
    left_b: np.ndarray,
    right_b: np.ndarray,
    half_width: float,
    length_weight: float = 0.0,
    weights: np.ndarray | None = None,
) -> np.ndarray:
    """One QP around the reference line ``ref``; returns the new points (``weights``: per point, the
    weight of its curvature in the objective).

    With ``length_weight`` ``w > 0`` the objective is ``(1 - w)`` times the curvature term plus ``w``
    times the sum of squared segment lengths (a shortest-path term), both scaled to the same mean
    diagonal: the compromise between the minimum-curvature and the shortest line of Braghin et al.
    """
    m = len(ref)
    normals = left_normals(ref, closed)
    hi = distance_to_polyline(ref, left_b) - half_width
    lo = -(distance_to_polyline(ref, right_b) - half_width)
    if np.any(lo > hi):
        raise ValueError("The road is narrower than the car somewhere: no line keeps the half-width clear.")
    if not closed:
        lo[0] = hi[0] = float(np.clip(0.0, lo[0], hi[0]))  # the car starts at the start line's centre
    h = float(np.mean(segment_lengths(ref, closed)))
    bend = second_difference(m, closed) / h**2
    if weights is not None:  # row i of the second difference is point i's (point i + 1's on open tracks)
        bend = bend * np.sqrt(weights if closed else weights[1:-1])[:, None]
    hess, grad = _quadratic(bend, ref, normals)
    if length_weight > 0:
        hess_s, grad_s = _quadratic(first_difference(m, closed) / h, ref, normals)
        ratio = float(np.mean(np.diag(hess))) / max(float(np.mean(np.diag(hess_s))), 1e-300)
        hess = (1.0 - length_weight) * hess + length_weight * ratio * hess_s
        grad = (1.0 - length_weight) * grad + length_weight * ratio * grad_s
    hess += RIDGE * float(np.mean(np.diag(hess))) * np.eye(m)
    offsets = solve_box_qp(hess, grad, lo, hi).x
    return ref + offsets[:, None] * normals


def _quadratic(d: np.ndarray, ref: np.ndarray, normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(H, g)`` of ``|D (ref + diag(a) n)|^2 / 2`` in the offsets ``a``, x and y summed."""
    ax = d * normals[:, 0][None, :]
    ay = d * normals[:, 1][None, :]
    hess = ax.T @ ax + ay.T @ ay
    grad = ax.T @ (d @ ref[:, 0]) + ay.T @ (d @ ref[:, 1])
    return hess, grad


def keep_clear(
    points: np.ndarray, borders: tuple[np.ndarray, np.ndarray], clearance: float, closed: bool
) -> np.ndarray:
    """Move points closer than ``clearance`` to a border, or past one, onto the road ``clearance`` from
    it (``borders``: the two :func:`border_polyline` of a track that is a loop when ``closed``).

    A distance is blind to the side of the border a point is on, so the side comes from
    :func:`inside_road`: the chords of a resampling can cut across a sharp border tip (penbay_pro_cw's
    inner border, by 0.7 mm at 0.2 m spacing), and pushing such a point "away" from the border would
    push it further off the road, where the next solve's corridor (distances again) would keep it.
    """
    pts = points.copy()
    rows = np.arange(len(pts))
    for _ in range(3):
        near = [nearest_on_polyline(pts, border) for border in borders]
        dists = np.column_stack([dist for _, dist in near])
        which = np.argmin(dists, axis=1)  # the nearer border: the one crossed, for a point off the road
        dist = dists[rows, which]
        feet = np.stack([feet for feet, _ in near], axis=1)[rows, which]
        side = np.where(inside_road(pts, borders, closed), 1.0, -1.0)
        move = (dist < clearance) | (side < 0)
        if not move.any():
            break
        away = side[move, None] * (pts[move] - feet[move]) / np.maximum(dist[move], 1e-12)[:, None]
        pts[move] = feet[move] + away * (clearance + 1e-9)
    return pts


def inside_road(points: np.ndarray, borders: tuple[np.ndarray, np.ndarray], closed: bool) -> np.ndarray:
    """Whether each point is between the two :func:`border_polyline` ``borders``, exactly (even-odd
    rule): on a loop the road between the two rings (DeepRacer's road polygon, as
    :func:`drx.sim.geometry.rasterise_road` draws it at 1 cm); on an open track the strip between the
    borders, each drawn on straight by :data:`OPEN_END` past both ends, so that a point on the start or
    finish line (where an open track's line begins and ends) is inside: those lines are not borders."""
    if closed:
        rings = list(borders)
    else:
        left, right = (_extended(border) for border in borders)
        rings = [np.vstack([left, right[::-1], left[:1]])]
    a = np.vstack([ring[:-1] for ring in rings])
    b = np.vstack([ring[1:] for ring in rings])
    slope = np.divide(b[:, 0] - a[:, 0], b[:, 1] - a[:, 1], out=np.zeros(len(a)), where=a[:, 1] != b[:, 1])
    inside = np.zeros(len(points), dtype=bool)
    for start in range(0, len(points), 256):  # chunks bound the (k, n) temporaries
        x = points[start : start + 256, 0:1]
        y = points[start : start + 256, 1:2]
        straddles = (a[None, :, 1] > y) != (b[None, :, 1] > y)
        crossing = a[None, :, 0] + (y - a[None, :, 1]) * slope[None, :]  # where a ray to +x meets the edge
        inside[start : start + 256] = np.sum(straddles & (x < crossing), axis=1) % 2 == 1
    return inside


def _extended(polyline: np.ndarray) -> np.ndarray:
    """An open polyline drawn on straight by :data:`OPEN_END` past both of its ends."""
    head = polyline[0] - polyline[1]
    tail = polyline[-1] - polyline[-2]
    before = polyline[0] + OPEN_END * head / max(float(np.linalg.norm(head)), 1e-12)
    after = polyline[-1] + OPEN_END * tail / max(float(np.linalg.norm(tail)), 1e-12)
    return np.vstack([before, polyline, after])


def first_difference(m: int, closed: bool) -> np.ndarray:
    """The ``(k, m)`` first-difference matrix: rows ``p[i+1] - p[i]`` (cyclic on loops)."""
    if closed:
        return np.roll(np.eye(m), 1, axis=1) - np.eye(m)
    return np.eye(m)[1:] - np.eye(m)[:-1]


def second_difference(m: int, closed: bool) -> np.ndarray:
    """The ``(k, m)`` second-difference matrix: rows ``p[i-1] - 2 p[i] + p[i+1]`` (cyclic on loops)."""
    if closed:
        d = -2.0 * np.eye(m) + np.roll(np.eye(m), 1, axis=1) + np.roll(np.eye(m), -1, axis=1)
        return d
    d = np.zeros((m - 2, m))
    idx = np.arange(m - 2)
    d[idx, idx] = 1.0
    d[idx, idx + 1] = -2.0
    d[idx, idx + 2] = 1.0
    return d


def _left_right(
    ref: np.ndarray, closed: bool, inner: np.ndarray, outer: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Return (left border, right border) as seen driving along ``ref``: a majority vote of all points."""
    normals = left_normals(ref, closed)
    foot, _ = nearest_on_polyline(ref, inner)
    votes = np.einsum("ij,ij->i", foot - ref, normals)
    return (inner, outer) if np.sum(votes > 0) >= np.sum(votes < 0) else (outer, inner)


# ----- polyline helpers -------------------------------------------------------------------------


def clean_polyline(points: np.ndarray, closed: bool) -> np.ndarray:
    """Drop repeated consecutive points and, on loops, the closing duplicate."""
    keep = np.ones(len(points), dtype=bool)
    keep[1:] = np.linalg.norm(np.diff(points, axis=0), axis=1) > 1e-9
    pts = points[keep]
    if closed and len(pts) > 2 and np.linalg.norm(pts[0] - pts[-1]) < 1e-9:
        pts = pts[:-1]
    return pts


def border_polyline(points: np.ndarray, closed: bool) -> np.ndarray:
    """A border as a polyline whose segments include the closing one on loops."""
    pts = clean_polyline(points, closed)
    return np.vstack([pts, pts[:1]]) if closed else pts


def segment_lengths(points: np.ndarray, closed: bool) -> np.ndarray:
    """Lengths [m] of the segments between consecutive points (with the closing one on loops)."""
    nxt = np.roll(points, -1, axis=0) if closed else points[1:]
    cur = points if closed else points[:-1]
    return np.linalg.norm(nxt - cur, axis=1)


def resample(points: np.ndarray, closed: bool, count: int) -> np.ndarray:
    """``count`` points equally spaced by arc length along a polyline (loops: no closing duplicate)."""
    pts = np.vstack([points, points[:1]]) if closed else points
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    total = s[-1]
    targets = np.linspace(0.0, total, count, endpoint=not closed)
    x = np.interp(targets, s, pts[:, 0])
    y = np.interp(targets, s, pts[:, 1])
    return np.column_stack([x, y])


def smooth(points: np.ndarray, closed: bool, sigma: float) -> np.ndarray:
    """Gaussian smoothing of a polyline's points (``sigma`` in points; wraps on loops, keeps open ends)."""
    if sigma <= 0:
        return points
    half = int(math.ceil(3 * sigma))
    kernel = np.exp(-0.5 * (np.arange(-half, half + 1) / sigma) ** 2)
    kernel /= kernel.sum()
    if closed:
        padded = np.vstack([points[-half:], points, points[:half]]) if half else points
    else:
        padded = np.vstack([np.repeat(points[:1], half, 0), points, np.repeat(points[-1:], half, 0)])
    out = np.column_stack([np.convolve(padded[:, k], kernel, mode="valid") for k in range(2)])
    if not closed:
        out[0], out[-1] = points[0], points[-1]
    return out


def left_normals(points: np.ndarray, closed: bool) -> np.ndarray:
    """Unit normals pointing left of the driving direction, from central differences."""
    if closed:
        tangent = np.roll(points, -1, axis=0) - np.roll(points, 1, axis=0)
    else:
        tangent = np.gradient(points, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    return np.column_stack([-tangent[:, 1], tangent[:, 0]])


def curvature(points: np.ndarray, closed: bool) -> np.ndarray:
    """Signed curvature [1/m] at each point: the circle through it and its two neighbours (+ = left)."""
    if closed:
        a, b, c = np.roll(points, 1, axis=0), points, np.roll(points, -1, axis=0)
    else:
        a = np.vstack([points[:1], points[:-1]])
        b = points
        c = np.vstack([points[1:], points[-1:]])
    ab, bc, ca = b - a, c - b, a - c
    cross = ab[:, 0] * bc[:, 1] - ab[:, 1] * bc[:, 0]
    denom = np.linalg.norm(ab, axis=1) * np.linalg.norm(bc, axis=1) * np.linalg.norm(ca, axis=1)
    return np.divide(2.0 * cross, denom, out=np.zeros(len(points)), where=denom > 1e-12)


def nearest_on_polyline(points: np.ndarray, line: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Nearest point on the polyline ``line`` to each of ``points``; returns ``(feet, distances)``."""
    a = line[:-1]
    d = line[1:] - a
    dd = np.einsum("ij,ij->i", d, d)
    inv = np.divide(1.0, dd, out=np.zeros_like(dd), where=dd > 0)
    feet = np.empty_like(points)
    dist = np.empty(len(points))
    for start in range(0, len(points), 256):  # chunks bound the (k, n, 2) temporaries
        p = points[start : start + 256]
        rel = p[:, None, :] - a[None, :, :]
        t = np.clip(np.einsum("kij,ij->ki", rel, d) * inv, 0.0, 1.0)
        foot = a[None] + t[..., None] * d[None]
        d2 = np.sum((p[:, None, :] - foot) ** 2, axis=2)
        best = np.argmin(d2, axis=1)
        rows = np.arange(len(p))
        feet[start : start + len(p)] = foot[rows, best]
        dist[start : start + len(p)] = np.sqrt(d2[rows, best])
    return feet, dist


def distance_to_polyline(points: np.ndarray, line: np.ndarray) -> np.ndarray:
    """Distance [m] from each point to the polyline ``line``."""
    return nearest_on_polyline(points, line)[1]
