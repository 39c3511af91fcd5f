"""Track geometry on the ten real DeepRacer routes, checked against the README table and brute force."""

from __future__ import annotations

import math

import numpy as np
import pytest

from drx.errors import DrxError, NotFoundError
from drx.sim.track import Track, load_track

from ._tracks import NAMES, TRACKS, shared_path, shared_track


def _dense(track: Track, step: float = 0.001) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Brute-force oracle: the centre line sampled every millimetre, with s and unit tangents."""
    s = np.arange(0.0, track.length, step)
    pts = track.point_at(s)
    tang = np.gradient(pts, axis=0)
    tang /= np.linalg.norm(tang, axis=1, keepdims=True)
    return s, pts, tang


@pytest.mark.parametrize("name", NAMES)
def test_length_direction_and_rows_match_readme(name: str) -> None:
    rows, loop, direction, length, _ = TRACKS[name]
    track = shared_track(name)
    assert track.closed is loop
    assert track.direction == direction
    if name == "China_eval_track":
        # Nearly closed: drx adds the 0.090 m closing segment DeepRacer's row list lacks.
        assert len(track.center) == rows + 1
        assert track.length == pytest.approx(length + 0.090, abs=2e-3)
        assert any("open by 0.090 m" in n for n in track.notes)
    else:
        assert len(track.center) == rows
        assert track.length == pytest.approx(length, abs=1e-3)
    if loop:
        assert track.waypoints[0] == track.waypoints[-1]


@pytest.mark.parametrize("name", NAMES)
def test_track_width_matches_readme_even_with_skewed_borders(name: str) -> None:
    width = TRACKS[name][4]
    track = shared_track(name)
    widths = np.array([track.project(x, y).width for x, y in track.center[:-1]])
    assert np.median(widths) == pytest.approx(width, abs=0.01)
    # Skewed borders never make the measured width exceed the real road by more than 2 cm.
    assert widths.max() <= width + 0.02
    rowwise = np.linalg.norm(track.inner - track.outer, axis=1)
    if name in ("Bowtie_track", "Oval_track", "Canada_Training"):
        assert rowwise.max() > width + 0.25  # the quirk: row-wise distance overstates the width


@pytest.mark.parametrize("name", NAMES)
def test_closest_waypoints_by_projection(name: str) -> None:
    track = shared_track(name)
    c = track.center
    for i in range(0, len(c) - 1):
        seg = c[i + 1] - c[i]
        if np.linalg.norm(seg) < 1e-9:
            continue
        # A point 30% along segment i, 5 cm to its left: behind i, ahead i+1.
        n = np.array([-seg[1], seg[0]]) / np.linalg.norm(seg)
        p = c[i] + 0.3 * seg + 0.05 * n
        proj = track.project(*p)
        assert [proj.prev_index, proj.next_index] == [i, i + 1], f"segment {i}"
        assert proj.distance == pytest.approx(0.05, abs=1e-3)
        assert proj.left


@pytest.mark.parametrize("name", NAMES)
def test_projection_matches_brute_force_on_random_road_points(name: str) -> None:
    track = shared_track(name)
    s_dense, pts, tang = _dense(track)
    rng = np.random.default_rng(0)
    s_q = rng.uniform(0, track.length, 60)
    off = rng.uniform(-0.3, 0.3, 60) * TRACKS[name][4]
    h = np.asarray(track.heading_at(s_q))
    q = track.point_at(s_q) + off[:, None] * np.stack([-np.sin(h), np.cos(h)], axis=1)
    for (x, y), o in zip(q, off, strict=True):
        d2 = (pts[:, 0] - x) ** 2 + (pts[:, 1] - y) ** 2
        k = int(np.argmin(d2))
        proj = track.project(x, y)
        assert proj.distance == pytest.approx(math.sqrt(d2[k]), abs=2e-3)
        if abs(o) > 0.01:
            cross = tang[k, 0] * (y - pts[k, 1]) - tang[k, 1] * (x - pts[k, 0])
            assert proj.left == (cross > 0)
        ds = abs(proj.s - s_dense[k])
        assert min(ds, track.length - ds) < 0.01 or proj.distance < 0.01


@pytest.mark.parametrize("name", NAMES)
def test_left_of_center_flips_with_direction(name: str) -> None:
    track = shared_track(name)
    rev = track.reversed()
    i = len(track.center) // 3
    # A point between the centre line and the inner border.
    p = 0.7 * track.center[i] + 0.3 * track.inner[i]
    fwd, back = track.project(*p), rev.project(*p)
    assert fwd.left != back.left
    assert fwd.distance == pytest.approx(back.distance, abs=1e-9)
    assert fwd.s + back.s == pytest.approx(track.length, abs=1e-6) or not track.closed
    if track.direction == "ccw":
        assert fwd.left  # the inside of a counter-clockwise loop is on the left
    elif track.direction == "cw":
        assert not fwd.left  # ... and on the right of a clockwise one
    assert rev.direction == {"ccw": "cw", "cw": "ccw", "-": "-"}[track.direction]
    assert rev.length == pytest.approx(track.length)
    np.testing.assert_array_equal(rev.reversed().center, track.center)


@pytest.mark.parametrize("name", NAMES)
def test_on_road_centre_borders_and_outside(name: str) -> None:
    track = shared_track(name)
    s = np.linspace(0.05, track.length - 0.05, 80)
    h = np.asarray(track.heading_at(s))
    normal = np.stack([-np.sin(h), np.cos(h)], axis=1)
    centre = track.point_at(s)
    half = np.array([track.width_at(v) for v in s]) / 2
    assert track.on_road(centre).all()
    for side in (1, -1):
        assert track.on_road(centre + side * (half - 0.03)[:, None] * normal).all()
        out = centre + side * (half + 0.03)[:, None] * normal
        # At the inside of a sharp vertex the normal offset can stay on the road: keep the points
        # whose true distance to the centre line is beyond the border.
        beyond = np.array(
            [track.project(x, y).distance > h + 0.02 for (x, y), h in zip(out, half, strict=True)]
        )
        assert beyond.sum() > 60
        assert not track.on_road(out[beyond]).any()
        assert not any(track.on_road_xy(x, y) for x, y in out[beyond])
    assert not track.on_road(np.array([[1e4, 1e4]]))[0]


@pytest.mark.parametrize("name", NAMES)
def test_projection_from_last_segment_agrees_with_global(name: str) -> None:
    track = shared_track(name)
    rng = np.random.default_rng(1)
    hint = None
    # A car's path: steps of up to 0.3 m (4 m/s at 15 Hz), wandering across the road.
    for s in np.arange(0.0, track.length, 0.27):
        h = float(track.heading_at(s))
        off = rng.uniform(-0.45, 0.45) * TRACKS[name][4]
        p = track.point_at(s) + off * np.array([-math.sin(h), math.cos(h)])
        walked = track.project(*p, hint=hint)
        whole = track.project(*p)
        assert walked.s == pytest.approx(whole.s, abs=1e-9) and walked.left == whole.left
        assert [walked.prev_index, walked.next_index] == [whole.prev_index, whole.next_index]
        hint = walked.segment
    # A hint far from the point falls back to the global search.
    far = track.project(*track.point_at(track.length / 2), hint=0)
    assert far.s == pytest.approx(track.length / 2, abs=1e-6)


def test_open_track_ends_at_the_far_end() -> None:
    track = shared_track("Straight_track")
    end = track.center[-1] + (track.center[-1] - track.center[-2])  # beyond the end
    proj = track.project(*end)
    assert [proj.prev_index, proj.next_index] == [21, 0]  # DeepRacer's find_prev_next wraps "next"
    assert proj.s == pytest.approx(track.length)
    assert not track.on_road(end[None])[0]


def test_repeated_points_are_kept_and_skipped() -> None:
    track = shared_track("reInvent2019_track")
    assert any("repeat the previous point" in n for n in track.notes)
    rep = int(np.flatnonzero(np.linalg.norm(np.diff(track.center, axis=0), axis=1) < 1e-9)[0])
    seg = track.center[rep + 2] - track.center[rep + 1]
    proj = track.project(*(track.center[rep + 1] + 0.5 * seg))
    assert [proj.prev_index, proj.next_index] == [rep + 1, rep + 2]
    assert math.isfinite(float(track.heading_at(track.cumulative[rep])))


def test_swapped_borders_are_fixed_and_reported() -> None:
    route = np.load(shared_path("reinvent_base"))
    swapped = route[:, [0, 1, 4, 5, 2, 3]]
    track, notes = Track.from_route(swapped, "swapped")
    assert any("swapped" in n for n in notes)
    np.testing.assert_array_equal(track.inner, route[:, 2:4])
    np.testing.assert_array_equal(track.to_route(), route)


@pytest.mark.parametrize(
    "bad", [np.zeros((10, 4)), np.zeros((2, 6)), np.full((5, 6), np.nan), np.zeros(6), "text"]
)
def test_malformed_routes_raise_drx_error(bad: object) -> None:
    with pytest.raises(DrxError):
        Track.from_route(bad, "bad")


def test_load_track_by_path_name_and_unknown(_drx_home) -> None:  # noqa: ANN001
    path = shared_path("Oval_track")
    assert load_track(path).name == "Oval_track"
    (_drx_home / "tracks").mkdir(parents=True)
    (_drx_home / "tracks" / "my_oval.npy").write_bytes(path.read_bytes())
    assert load_track("my_oval").length == pytest.approx(19.55, abs=1e-3)
    with pytest.raises(NotFoundError, match="did you mean 'my_oval'"):  # a near match, imported or shipped
        load_track("my_ovl")
    with pytest.raises(NotFoundError, match="'Oval_track' \\(Oval Track\\)"):
        load_track("Oval_trak")


def test_corners_find_the_turns() -> None:
    base = shared_track("reinvent_base")
    corners = base.corners()
    assert 3 <= len(corners) <= 8
    assert sum(c.angle_deg for c in corners) == pytest.approx(360, abs=60)  # a CCW loop turns left
    assert min(c.radius for c in corners) < 1.0
    assert shared_track("Straight_track").corners() == []
    cw = shared_track("reInvent2019_wide_cw").corners()
    assert sum(c.angle_deg for c in cw) < -270


def test_loop_closing_rules() -> None:
    route = np.load(shared_path("reinvent_base"))
    # Borders off by a rounding error at the closing row: still the same loop, no row added.
    nudged = route.copy()
    nudged[-1, 2] += 1e-12
    track, notes = Track.from_route(nudged, "nudged")
    assert track.closed and len(track.center) == len(route) and notes == []
    # The closing row dropped: closed again by adding it, and said so.
    track, notes = Track.from_route(route[:-1], "open")
    assert track.closed and len(track.center) == len(route)
    assert track.length == pytest.approx(17.709, abs=1e-3) and "open by" in notes[0]
    # Half a loop is an open track.
    half = Track.from_route(route[: len(route) // 2], "half")[0]
    assert not half.closed and half.direction == "-"
