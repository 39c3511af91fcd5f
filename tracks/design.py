"""Design drx's own race tracks and write them in DeepRacer's route format.

Each track is a handful of control points (metres). A closed, periodic cubic
spline runs through them (chord-length parameterised, so it is C2: no kinks,
no curvature jumps); the centre line is resampled along it every ~0.17 m, as
DeepRacer's own routes are; the borders are offset by +-width/2 along the
normal. The result is written as ``drx/tracks/drx/<name>.npy`` (package data, so
``pip install drx`` ships them): float64, shape (N, 6), columns ``center_x,
center_y, inner_x, inner_y, outer_x, outer_y``, row 0 on the start line, rows in
driving order, the closing duplicate row included, and ``inner`` the geometric
inside border whatever the driving direction.

Every track is checked before it is written (the script stops otherwise):
the centre line's tightest radius leaves room for half the road plus a margin,
no border crosses itself or the other border, and non-neighbouring parts of the
road keep a grass gap between them.

Run it from the repository root::

    python tracks/design.py            # writes drx/tracks/drx/*.npy
    python tracks/design.py --png /tmp # also draws each track to /tmp/<name>.png
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path

import numpy as np

OUT = Path(__file__).resolve().parents[1] / "drx" / "tracks" / "drx"  # the package's folder of drx's tracks
SPACING = 0.17  # [m] target distance between centre-line rows
RADIUS_MARGIN = 0.2  # [m] tightest centre radius must exceed width/2 + this
GRASS_GAP = 0.35  # [m] least grass between two parts of the road that are not neighbours


@dataclass(frozen=True)
class Design:
    """A track design: control points (in driving order) and the road width."""

    name: str
    width: float  # [m]
    points: tuple[tuple[float, float], ...]  # control points, first one on the start line
    character: str  # one line for the README

    @property
    def direction(self) -> str:
        """``ccw`` or ``cw``, from the signed area of the control polygon."""
        return "ccw" if _signed_area(np.asarray(self.points, dtype=float)) > 0 else "cw"


# ----- the tracks -------------------------------------------------------------
# Coordinates in metres; the first point is the start line; points run in the
# driving direction. Counter-clockwise unless the name says otherwise.
# fmt: off

OVAL = Design(
    "oval",
    1.07,
    (
        (4.15, 0.6), (5.5, 0.6), (6.7, 0.85), (7.55, 1.6), (7.7, 2.35), (7.55, 3.1), (6.7, 3.85),
        (5.5, 4.1), (4.15, 4.1), (2.8, 4.1), (1.6, 3.85), (0.75, 3.1), (0.6, 2.35), (0.75, 1.6),
        (1.6, 0.85), (2.8, 0.6),
    ),
    "beginner oval: two straights joined by wide, constant turns",
)

KIDNEY = Design(
    "kidney",
    1.07,
    (
        (3.75, 0.64), (5.56, 0.7), (7.06, 1.18), (7.92, 2.25), (7.81, 3.53), (6.85, 4.39), (5.46, 4.39),
        (4.39, 3.69), (3.32, 3.69), (2.14, 4.39), (0.96, 4.17), (0.43, 3.1), (0.54, 1.82), (1.6, 0.86),
    ),
    "gentle kidney bean: sweeping left turns and one soft right-hand dip on the back straight",
)

HAIRPIN = Design(
    "hairpin",
    1.07,
    (
        (3.0, 0.6), (4.5, 0.6), (6.0, 0.65), (7.6, 1.0), (8.4, 2.0), (8.2, 3.1), (7.2, 3.5),
        (5.8, 3.0), (5.1, 2.85), (4.4, 2.9), (3.69, 3.19), (3.4, 3.9),
        (3.69, 4.61), (4.4, 4.9), (5.3, 5.02),
        (6.3, 5.07), (7.2, 5.07), (7.91, 5.36), (8.2, 6.07), (7.91, 6.78), (7.2, 7.07), (5.2, 7.07),
        (3.0, 7.0), (1.2, 6.6), (0.45, 5.4), (0.45, 2.5), (0.75, 1.2), (1.6, 0.65),
    ),
    "long straight, a sweeper, then one tight 180 degree hairpin that tests braking",
)

SPEEDWAY = Design(
    "speedway",
    1.07,
    (
        (5.0, 0.6), (7.5, 0.6), (9.6, 0.9), (11.0, 1.9), (11.5, 3.4), (11.2, 4.9), (10.0, 6.0),
        (8.2, 6.5), (6.3, 6.2), (5.0, 5.75), (3.6, 6.2), (2.0, 6.3), (0.9, 5.5), (0.5, 4.0),
        (0.6, 2.4), (1.3, 1.2), (2.8, 0.65),
    ),
    "fast and flowing: long straights, wide sweepers and a kink on the back straight",
)

TECHNICAL = Design(
    "technical",
    0.90,
    (
        (4.0, 0.6), (6.0, 0.6), (8.0, 0.6), (9.0, 0.9), (9.7, 1.5), (10.7, 1.8), (11.7, 1.5),
        (12.6, 1.0), (13.9, 1.0), (14.9, 1.6), (15.3, 2.7), (15.0, 3.8), (14.1, 4.3), (13.0, 4.3),
        (12.2, 4.9), (12.3, 5.9), (13.2, 6.5), (14.5, 6.7), (15.3, 7.4), (15.3, 8.5),
        (14.4, 9.2), (12.8, 9.3), (11.2, 9.0), (10.2, 8.3), (9.4, 7.3), (8.3, 6.9),
        (7.4, 7.5), (6.8, 8.5), (5.8, 9.2), (4.2, 9.3), (2.6, 9.1), (1.2, 8.6), (0.6, 7.5),
        (1.0, 6.4), (2.2, 6.0), (3.5, 5.8), (4.3, 5.0), (4.0, 4.1), (2.9, 3.7), (1.5, 3.4),
        (0.65, 2.6), (0.7, 1.4), (1.8, 0.7),
    ),
    "long technical circuit: chicanes, an S-section, a tight right, hairpins and varied corners",
)

KIDNEY_CW = Design(
    "kidney-cw",
    1.07,
    KIDNEY.points[:1] + tuple(reversed(KIDNEY.points[1:])),
    "the kidney driven clockwise: left and right of centre swap, the dip becomes a left",
)

# fmt: on

DESIGNS: tuple[Design, ...] = (OVAL, KIDNEY, HAIRPIN, SPEEDWAY, TECHNICAL, KIDNEY_CW)


# ----- geometry ---------------------------------------------------------------
def _signed_area(poly: np.ndarray) -> float:
    """Shoelace area of a closed polygon (no duplicate row); > 0 when counter-clockwise."""
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def periodic_spline(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Coefficients of the closed cubic spline through ``points`` (chord-length knots).

    Returns ``(knots, coef)``: ``knots`` has n+1 entries (0 .. total chord), and
    segment i is ``p(t) = a + b*u + c*u**2 + d*u**3`` with ``u = t - knots[i]``
    and ``coef[i] = (a, b, c, d)``, each a 2-vector.
    """
    n = len(points)
    h = np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1)  # segment chord lengths
    # Second derivatives M_i of a periodic spline: h[i-1] M[i-1] + 2(h[i-1]+h[i]) M[i] + h[i] M[i+1] = rhs.
    a = np.zeros((n, n))
    rhs = np.zeros((n, 2))
    for i in range(n):
        hp, hn = h[i - 1], h[i]
        a[i, i - 1] += hp
        a[i, i] += 2.0 * (hp + hn)
        a[i, (i + 1) % n] += hn
        rhs[i] = 6.0 * ((points[(i + 1) % n] - points[i]) / hn - (points[i] - points[i - 1]) / hp)
    m = np.linalg.solve(a, rhs)
    m_next = np.roll(m, -1, axis=0)
    p_next = np.roll(points, -1, axis=0)
    hh = h[:, None]
    coef = np.stack(
        [
            points,
            (p_next - points) / hh - hh * (2.0 * m + m_next) / 6.0,
            m / 2.0,
            (m_next - m) / (6.0 * hh),
        ],
        axis=1,
    )
    knots = np.concatenate([[0.0], np.cumsum(h)])
    return knots, coef


def _evaluate(knots: np.ndarray, coef: np.ndarray, t: np.ndarray, order: int = 0) -> np.ndarray:
    """The spline (order 0), its first (1) or second (2) derivative at parameters ``t``."""
    t = np.mod(t, knots[-1])
    i = np.clip(np.searchsorted(knots, t, side="right") - 1, 0, len(coef) - 1)
    u = (t - knots[i])[:, None]
    a, b, c, d = (coef[i, k] for k in range(4))
    if order == 0:
        return a + u * (b + u * (c + u * d))
    if order == 1:
        return b + u * (2.0 * c + 3.0 * u * d)
    return 2.0 * c + 6.0 * u * d


def build_route(design: Design, spacing: float = SPACING) -> np.ndarray:
    """The (N, 6) route of a design, closing duplicate row included."""
    knots, coef = periodic_spline(np.asarray(design.points, dtype=float))
    # Arc length along a fine sampling, then rows at equal arc-length steps.
    fine_t = np.linspace(0.0, knots[-1], 400 * len(coef) + 1)
    fine = _evaluate(knots, coef, fine_t)
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(fine, axis=0), axis=1))])
    rows = max(8, round(arc[-1] / spacing))
    t = np.interp(np.linspace(0.0, arc[-1], rows + 1), arc, fine_t)
    center = _evaluate(knots, coef, t)
    center[-1] = center[0]  # exact closing duplicate
    tangent = _evaluate(knots, coef, t, order=1)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    left = np.stack([-tangent[:, 1], tangent[:, 0]], axis=1)  # left of the driving direction
    inside = left if design.direction == "ccw" else -left  # the inside is on the left when CCW
    inside[-1] = inside[0]
    half = design.width / 2.0
    inner = center + half * inside
    outer = center - half * inside
    return np.hstack([center, inner, outer]).astype(np.float64)


def min_radius(design: Design) -> float:
    """The tightest radius of curvature of the centre line [m]."""
    knots, coef = periodic_spline(np.asarray(design.points, dtype=float))
    t = np.linspace(0.0, knots[-1], 20000, endpoint=False)
    d1 = _evaluate(knots, coef, t, order=1)
    d2 = _evaluate(knots, coef, t, order=2)
    cross = np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])
    speed = np.linalg.norm(d1, axis=1)
    curvature = cross / speed**3
    return float(1.0 / curvature.max())


def polyline_length(xy: np.ndarray) -> float:
    """Length of a polyline [m]."""
    return float(np.sum(np.linalg.norm(np.diff(xy, axis=0), axis=1)))


def _segments_cross(a0: np.ndarray, a1: np.ndarray, b0: np.ndarray, b1: np.ndarray) -> np.ndarray:
    """Pairwise proper-intersection matrix of segments a0->a1 (rows) and b0->b1 (columns)."""

    def orient(p: np.ndarray, q: np.ndarray, r: np.ndarray) -> np.ndarray:
        return (q[..., 0] - p[..., 0]) * (r[..., 1] - p[..., 1]) - (q[..., 1] - p[..., 1]) * (
            r[..., 0] - p[..., 0]
        )

    p, q = a0[:, None, :], a1[:, None, :]
    r, s = b0[None, :, :], b1[None, :, :]
    d1, d2 = orient(p, q, r), orient(p, q, s)
    d3, d4 = orient(r, s, p), orient(r, s, q)
    return (d1 * d2 < 0) & (d3 * d4 < 0)


def crossings(a: np.ndarray, b: np.ndarray, same: bool) -> int:
    """How many segment pairs of closed polylines ``a`` and ``b`` cross (neighbours excluded when same)."""
    hits = _segments_cross(a[:-1], a[1:], b[:-1], b[1:])
    if same:
        n = len(a) - 1
        i, j = np.indices(hits.shape)
        gap = np.abs(i - j)
        hits &= np.minimum(gap, n - gap) > 1
    return int(np.count_nonzero(hits))


def min_grass_gap(route: np.ndarray, width: float) -> float:
    """The grass between two parts of the road that are not neighbours [m].

    That is the least distance between two centre points that lie more than a
    tight half turn apart along the road, minus the road width.
    """
    c = route[:-1, :2]
    n = len(c)
    step = polyline_length(route[:, :2]) / n
    d = np.linalg.norm(c[:, None, :] - c[None, :, :], axis=2)
    i, j = np.indices(d.shape)
    along = np.minimum(np.abs(i - j), n - np.abs(i - j)) * step
    far = along > np.pi * (width + GRASS_GAP)  # beyond any half turn of the tightest allowed corner
    return float(d[far].min() - width) if far.any() else float("inf")


def check(design: Design, route: np.ndarray) -> dict[str, float | str | int]:
    """Assert the route is a valid, drivable track and return its facts."""
    assert route.shape[1] == 6 and route.dtype == np.float64, design.name
    assert np.array_equal(route[0], route[-1]), f"{design.name}: the loop is not closed"
    r_min = min_radius(design)
    need = design.width / 2.0 + RADIUS_MARGIN
    assert r_min > need, f"{design.name}: tightest radius {r_min:.2f} m < width/2 + margin = {need:.2f} m"
    center, inner, outer = route[:, 0:2], route[:, 2:4], route[:, 4:6]
    for label, a, b, same in (
        ("inner border crosses itself", inner, inner, True),
        ("outer border crosses itself", outer, outer, True),
        ("borders cross each other", inner, outer, False),
    ):
        assert crossings(a, b, same) == 0, f"{design.name}: {label}"
    gap = min_grass_gap(route, design.width)
    assert gap > GRASS_GAP, f"{design.name}: only {gap:.2f} m of grass between two parts of the road"
    ccw = _signed_area(center[:-1]) > 0
    assert ccw == (design.direction == "ccw"), design.name
    assert abs(_signed_area(inner[:-1])) < abs(_signed_area(outer[:-1])), f"{design.name}: inner is outside"
    return {
        "name": design.name,
        "rows": len(route),
        "length": round(polyline_length(center), 3),
        "width": design.width,
        "direction": design.direction.upper(),
        "min_radius": round(r_min, 2),
        "grass_gap": round(gap, 2),
    }


def draw(route: np.ndarray, title: str, path: Path) -> None:
    """Draw a route to a PNG: road in grey, borders, centre line, start line and direction arrow."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    center, inner, outer = route[:, 0:2], route[:, 2:4], route[:, 4:6]
    fig, ax = plt.subplots(figsize=(8, 6))
    ax.fill(outer[:, 0], outer[:, 1], color="0.75")
    ax.fill(inner[:, 0], inner[:, 1], color="#8fc98f")
    ax.plot(inner[:, 0], inner[:, 1], "b-", lw=1, label="inner")
    ax.plot(outer[:, 0], outer[:, 1], "r-", lw=1, label="outer")
    ax.plot(center[:, 0], center[:, 1], "k--", lw=0.7, label="centre")
    ax.plot([inner[0, 0], outer[0, 0]], [inner[0, 1], outer[0, 1]], "k-", lw=3, label="start")
    ax.annotate("", xy=center[4], xytext=center[0], arrowprops={"arrowstyle": "->", "lw": 2})
    ax.set_aspect("equal")
    ax.set_title(title)
    ax.legend(loc="upper right", fontsize=7)
    fig.savefig(path, dpi=90)
    plt.close(fig)


def main() -> None:
    """Build, check and write every design."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=OUT, help="folder for the .npy files")
    parser.add_argument("--png", type=Path, default=None, help="also draw each track into this folder")
    args = parser.parse_args()
    for design in DESIGNS:
        route = build_route(design)
        facts = check(design, route)
        np.save(args.out / f"{design.name}.npy", route)
        if args.png is not None:
            title = f"{design.name}: {facts['length']} m, {design.width} m wide"
            draw(route, title, args.png / f"{design.name}.png")
        print("  ".join(f"{k}={v}" for k, v in facts.items()))


if __name__ == "__main__":
    main()
