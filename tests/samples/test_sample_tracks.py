"""drx's own tracks (drx/tracks/drx, made by tracks/design.py): valid DeepRacer routes that match
tracks/README.md and copy nothing."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from ._paths import SHARED_TRACKS, TRACK_FILES, TRACKS_DIR, load_module

IDS = [p.stem for p in TRACK_FILES]


def _readme_table() -> dict[str, dict[str, float | str | int]]:
    """The table of tracks/README.md: name -> length, width, rows, direction, radius."""
    rows = {}
    text = (TRACKS_DIR / "README.md").read_text(encoding="utf-8")
    pattern = r"^\| `([\w-]+)\.npy` \| ([\d.]+) \| ([\d.]+) \| (\d+) \| (CCW|CW) \| ([\d.]+) \|"
    for m in re.finditer(pattern, text, flags=re.MULTILINE):
        rows[m.group(1)] = {
            "length": float(m.group(2)),
            "width": float(m.group(3)),
            "rows": int(m.group(4)),
            "direction": m.group(5).lower(),
            "radius": float(m.group(6)),
        }
    return rows


README = _readme_table()


def _signed_area(poly: np.ndarray) -> float:
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))


def _crossing_pairs(a: np.ndarray, b: np.ndarray) -> list[tuple[int, int]]:
    """Index pairs (i, j) where segment a[i]a[i+1] properly crosses segment b[j]b[j+1] (brute force)."""
    p, r = a[:-1], a[1:] - a[:-1]
    q, s = b[:-1], b[1:] - b[:-1]
    rxs = r[:, None, 0] * s[None, :, 1] - r[:, None, 1] * s[None, :, 0]
    qp = q[None, :, :] - p[:, None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (qp[..., 0] * s[None, :, 1] - qp[..., 1] * s[None, :, 0]) / rxs
        u = (qp[..., 0] * r[:, None, 1] - qp[..., 1] * r[:, None, 0]) / rxs
    eps = 1e-9
    hit = (np.abs(rxs) > eps) & (t > eps) & (t < 1 - eps) & (u > eps) & (u < 1 - eps)
    return [(int(i), int(j)) for i, j in zip(*np.nonzero(hit), strict=True)]


def _load(path: Path) -> np.ndarray:
    return np.load(path, allow_pickle=False)


def test_at_least_five_tracks_and_readme_lists_each() -> None:
    assert len(TRACK_FILES) >= 5
    assert set(IDS) == set(README), "tracks/README.md must list exactly the .npy files in tracks/"
    assert {"oval", "technical"} <= set(IDS)
    assert any(row["direction"] == "cw" for row in README.values())


@pytest.mark.parametrize("path", TRACK_FILES, ids=IDS)
def test_deepracer_route_format(path: Path) -> None:
    route = _load(path)
    assert route.dtype == np.float64
    assert route.ndim == 2 and route.shape[1] == 6
    assert np.all(np.isfinite(route))
    assert np.array_equal(route[0], route[-1]), "a loop's last row repeats the first"
    step = np.linalg.norm(np.diff(route[:, 0:2], axis=0), axis=1)
    assert step.min() > 0.1 and step.max() < 0.25, "rows ~0.15-0.2 m apart, like DeepRacer's"
    assert np.ptp(step) < 0.01, "rows evenly spaced"


@pytest.mark.parametrize("path", TRACK_FILES, ids=IDS)
def test_matches_readme(path: Path) -> None:
    facts = README[path.stem]
    route = _load(path)
    center, inner, outer = route[:, 0:2], route[:, 2:4], route[:, 4:6]
    assert len(route) == facts["rows"]
    length = float(np.sum(np.linalg.norm(np.diff(center, axis=0), axis=1)))
    assert length == pytest.approx(facts["length"], abs=0.01)
    width = np.linalg.norm(inner - outer, axis=1)
    assert width == pytest.approx(np.full(len(route), facts["width"]), abs=1e-6)
    # Each row's borders sit half a width either side of its centre point.
    assert np.allclose(0.5 * (inner + outer), center, atol=1e-9)
    direction = "ccw" if _signed_area(center[:-1]) > 0 else "cw"
    assert direction == facts["direction"]


@pytest.mark.parametrize("path", TRACK_FILES, ids=IDS)
def test_inner_is_the_geometric_inside(path: Path) -> None:
    route = _load(path)
    inner_area = abs(_signed_area(route[:-1, 2:4]))
    center_area = abs(_signed_area(route[:-1, 0:2]))
    outer_area = abs(_signed_area(route[:-1, 4:6]))
    assert inner_area < center_area < outer_area


@pytest.mark.parametrize("path", TRACK_FILES, ids=IDS)
def test_borders_never_cross(path: Path) -> None:
    route = _load(path)
    inner, outer = route[:, 2:4], route[:, 4:6]
    assert _crossing_pairs(inner, outer) == []
    n = len(route) - 1
    for border in (inner, outer):
        pairs = [(i, j) for i, j in _crossing_pairs(border, border) if min(abs(i - j), n - abs(i - j)) > 1]
        assert pairs == [], f"a border crosses itself at segments {pairs[:3]}"


@pytest.mark.parametrize("path", TRACK_FILES, ids=IDS)
def test_road_does_not_fold_or_overlap(path: Path) -> None:
    """No border point lies closer to the centre line than half the width.

    That fails where a corner is tighter than half the road (the inside border
    folds) and where two parts of the road overlap.
    """
    route = _load(path)
    center = route[:-1, 0:2]
    half = 0.5 * float(np.linalg.norm(route[0, 2:4] - route[0, 4:6]))
    for border in (route[:-1, 2:4], route[:-1, 4:6]):
        d = np.linalg.norm(border[:, None, :] - center[None, :, :], axis=2).min(axis=1)
        assert d.min() >= half - 1e-6


@pytest.mark.parametrize("path", TRACK_FILES, ids=IDS)
def test_design_script_regenerates_the_file(path: Path) -> None:
    design = load_module(TRACKS_DIR / "design.py")
    by_name = {d.name: d for d in design.DESIGNS}
    assert path.stem in by_name, "every track comes from tracks/design.py"
    d = by_name[path.stem]
    route = design.build_route(d)
    facts = design.check(d, route)  # asserts radius, crossings, grass gap, direction
    assert np.allclose(route, _load(path), atol=1e-9)
    assert facts["min_radius"] == pytest.approx(README[path.stem]["radius"], abs=0.01)
    assert facts["min_radius"] > d.width / 2 + design.RADIUS_MARGIN


def test_none_is_a_copy_of_a_deepracer_track() -> None:
    if not SHARED_TRACKS.is_dir():
        pytest.skip(f"{SHARED_TRACKS} is absent: the real DeepRacer tracks live in ../shared/tracks")
    shared = sorted(SHARED_TRACKS.glob("*.npy"))
    assert shared, f"no .npy files in {SHARED_TRACKS}"
    for ours in TRACK_FILES:
        mine = _load(ours)
        for theirs_path in shared:
            assert ours.read_bytes() != theirs_path.read_bytes(), f"{ours.name} is {theirs_path.name}"
            theirs = np.load(theirs_path, allow_pickle=False)
            if theirs.shape == mine.shape:
                assert not np.allclose(mine, theirs, atol=1e-3), f"{ours.name} copies {theirs_path.name}"


@pytest.mark.parametrize("path", TRACK_FILES, ids=IDS)
def test_drx_reads_it_without_fixes(path: Path) -> None:
    track_mod = pytest.importorskip("drx.sim.track")
    facts = README[path.stem]
    track, notes = track_mod.Track.from_route(_load(path), name=path.stem)
    assert notes == []
    assert track.closed
    assert track.direction == facts["direction"]
    assert track.length == pytest.approx(facts["length"], abs=0.01)
    for s in np.linspace(0.0, track.length, 7, endpoint=False):
        assert track.width_at(float(s)) == pytest.approx(facts["width"], abs=0.02)
