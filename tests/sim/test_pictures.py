"""The top-down picture for people and the shared track painter."""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from drx.sim.camera_painter import (
    DEFAULT_COLORS,
    GroundFrame,
    paint_track,
    paint_walls,
    to_gray,
)
from drx.sim.pictures import TopDownRenderer, track_picture
from drx.sim.scene import FieldBox

SHARED = Path(__file__).resolve().parents[2].parent / "shared" / "tracks"


def straight(length: float = 4.0, width: float = 0.6) -> Any:
    """A synthetic open straight along +x from (0, 0), 0.1 m between rows."""
    xs = np.linspace(0.0, length, int(length / 0.1) + 1)
    center = np.column_stack([xs, np.zeros_like(xs)])
    return SimpleNamespace(
        name="straight",
        center=center,
        inner=center + [0.0, width / 2],
        outer=center - [0.0, width / 2],
        closed=False,
    )


def ring(radius: float = 2.0, width: float = 0.76, n: int = 80) -> Any:
    """A synthetic CCW circle of centre (0, 0), closing duplicate kept."""
    a = np.linspace(0.0, 2 * math.pi, n + 1)
    a[-1] = 0.0
    unit = np.column_stack([np.cos(a), np.sin(a)])
    return SimpleNamespace(
        name="ring",
        center=unit * radius,
        inner=unit * (radius - width / 2),
        outer=unit * (radius + width / 2),
        closed=True,
    )


def load_route(path: Path) -> Any:
    """A real DeepRacer route as a drx Track, or as a bare object with the attributes the renderer reads."""
    route = np.load(path)
    try:
        from drx.sim.track import Track
    except ImportError:
        closed = bool(np.allclose(route[0], route[-1]))
        return SimpleNamespace(
            name=path.stem, center=route[:, 0:2], inner=route[:, 2:4], outer=route[:, 4:6], closed=closed
        )
    return Track.from_route(route, path.stem)[0]


def test_to_gray_uses_deepracer_weights() -> None:
    assert to_gray((255, 255, 255)) == 255
    assert to_gray((100, 0, 0)) == round(29.89)
    assert to_gray((0, 100, 0)) == round(58.70)
    assert to_gray((0, 0, 100)) == round(11.40)


def test_paint_track_gray() -> None:
    """DeepRacer's sizes (reinvent_base.dae): 7.62 cm border lines inside the road, 2.54 cm wide
    centre-line dashes 5.08 cm long every 10.16 cm."""
    track = straight()  # road from y = -0.3 to 0.3
    frame = GroundFrame.fit(track, 0.005, 0.5)
    canvas = np.full((frame.height, frame.width), to_gray(DEFAULT_COLORS.ground), np.uint8)
    paint_track(canvas, track, frame)

    def at(x: float, y: float) -> int:
        c, r = np.round(frame.to_px(np.array([[x, y]]))[0]).astype(int)
        return int(canvas[r, c])

    road, border, center = (to_gray(DEFAULT_COLORS.road), to_gray(DEFAULT_COLORS.border),
                            to_gray(DEFAULT_COLORS.center))  # fmt: skip
    assert at(2.0, 0.15) == road  # on the road, off the centre line
    for y in (0.29, 0.23, -0.29, -0.23):  # the border lines: from the border 7.62 cm inwards
        assert at(2.0, y) == border, y
    assert at(2.0, 0.3 - 0.09) == road and at(2.0, -0.3 + 0.09) == road
    assert at(2.0, 0.32) == to_gray(DEFAULT_COLORS.ground)  # off the track: no paint outside
    assert at(0.0, 0.15) == to_gray(DEFAULT_COLORS.start)  # the start line
    assert at(4.0, 0.15) == to_gray(DEFAULT_COLORS.start)  # an open track's finish line
    # dashes: painted from k * 0.1016 to k * 0.1016 + 0.0508 m, 2.54 cm wide
    for k in (3, 10, 20):
        assert at(k * 0.1016 + 0.025, 0.0) == center, k
        assert at(k * 0.1016 + 0.075, 0.0) == road, k
    assert at(10 * 0.1016 + 0.025, 0.0105) == center and at(10 * 0.1016 + 0.025, 0.025) == road
    # the camera's ground leaves the start line out (reinvent_base has none)
    bare = np.full_like(canvas, to_gray(DEFAULT_COLORS.ground))
    paint_track(bare, track, frame, start_line=False)
    c, r = np.round(frame.to_px(np.array([[0.0, 0.15]]))[0]).astype(int)
    assert int(bare[r, c]) == road


def test_paint_walls_split_at_the_corners() -> None:
    frame = GroundFrame(x0=-2.0, y1=2.0, res=0.01, width=401, height=401)
    canvas = np.zeros((401, 401), np.uint8)
    paint_walls(canvas, frame, FieldBox(-1.0, -1.0, 1.0, 1.0), [10, 20, 30, 40])

    def at(x: float, y: float) -> int:
        c, r = np.round(frame.to_px(np.array([[x, y]]))[0]).astype(int)
        return int(canvas[r, c])

    assert at(0.0, 0.0) == 0 and at(0.95, 0.95) == 0  # inside the field: untouched
    assert (at(-1.5, 0.0), at(1.5, 0.0), at(0.0, -1.5), at(0.0, 1.5)) == (10, 20, 30, 40)
    assert at(-1.5, 1.2) == 10 and at(-1.2, 1.5) == 40  # beyond a corner: the nearer wall


def test_top_down_shape_and_background_untouched() -> None:
    renderer = TopDownRenderer(ring(), size=(320, 240))
    before = renderer.background.copy()
    img = renderer.render(2.0, 0.0, math.pi / 2)
    assert img.shape == (240, 320, 3) and img.dtype == np.uint8
    np.testing.assert_array_equal(renderer.background, before)
    # the whole ring fits: road colour near every edge of its bounding box
    road = np.all(np.abs(img.astype(int) - np.array(DEFAULT_COLORS.road)) < 6, axis=2)
    rows, cols = np.nonzero(road)
    assert rows.min() > 0 and rows.max() < 239 and cols.min() > 0 and cols.max() < 319


def test_car_drawn_where_it_is() -> None:
    track = ring()
    renderer = TopDownRenderer(track, size=(400, 400))
    red = np.array([220, 30, 30])
    for x, y, yaw in [(2.0, 0.0, math.pi / 2), (0.0, 2.0, math.pi), (-1.5, -1.0, 0.3)]:
        img = renderer.render(x, y, yaw)
        diff = np.any(img != renderer.background, axis=2)
        rows, cols = np.nonzero(diff)
        body = renderer.car_polygon(x, y, yaw).mean(axis=0)  # body centre, half a wheelbase ahead
        c, r = renderer.frame.to_px(body[None])[0]
        assert abs(cols.mean() - c) < 2 and abs(rows.mean() - r) < 2
        is_red = np.all(np.abs(img.astype(int) - red) < 40, axis=2)
        ri, ci = int(round(r)), int(round(c))
        assert is_red[ri - 8 : ri + 9, ci - 8 : ci + 9].sum() > 30, "a red body around its centre"
        # the car is the only change, and it is small
        assert diff.sum() < 0.01 * diff.size
    # the body centre lies half a wheelbase ahead of the rear axle, along the heading
    poly = renderer.car_polygon(0.0, 0.0, 0.0)
    assert poly.mean(axis=0) == pytest.approx([0.082, 0.0])
    nose = (poly[0] + poly[1]) / 2
    assert nose[0] > 0.082


def test_trail_inset_and_text() -> None:
    track = ring()
    renderer = TopDownRenderer(track, size=(640, 480))
    base = renderer.render(2.0, 0.0, math.pi / 2)
    a = np.linspace(0.0, math.pi / 2, 30)
    trail = np.column_stack([2 * np.cos(a), 2 * np.sin(a)])
    with_trail = renderer.render(2.0, 0.0, math.pi / 2, trail=trail)
    c, r = np.round(renderer.frame.to_px(trail[15:16])[0]).astype(int)
    assert np.any(with_trail[r, c] != base[r, c])

    frame = np.zeros((120, 160), np.uint8)
    frame[:, 80:] = 255
    inset = renderer.render(2.0, 0.0, math.pi / 2, camera_frame=frame)
    # top-right corner: a white-framed copy of the camera frame, dark left half and bright right half
    corner = inset[:170, -230:]
    assert (corner == 0).all(axis=2).sum() > 5000
    assert (corner == 255).all(axis=2).sum() > 5000
    stereo = renderer.render(2.0, 0.0, math.pi / 2, camera_frame=np.stack([frame, frame], axis=2))
    np.testing.assert_array_equal(stereo, inset)

    # a car under the top-right corner moves the inset to the bottom-right corner
    fr = renderer.frame
    x, y = fr.x0 + (fr.width - 60) * fr.res, fr.y1 - 60 * fr.res
    moved = renderer.render(x, y, 0.0, camera_frame=frame)
    assert (moved[:170, -230:] == 0).all(axis=2).sum() < 1000
    assert (moved[-170:, -230:] == 0).all(axis=2).sum() > 5000

    text = renderer.render(2.0, 0.0, math.pi / 2, text_lines=["progress 12.5%", "speed 1.0 m/s"])
    assert np.any(text[:60, :200] != base[:60, :200])
    assert np.array_equal(text[200:, :], base[200:, :])


def test_boxes_on_top_down() -> None:
    renderer = TopDownRenderer(ring(), size=(400, 400))
    img = renderer.render(2.0, 0.0, math.pi / 2, boxes=[(0.0, 2.0, 0.0, 0.3, 0.3)])
    c, r = np.round(renderer.frame.to_px(np.array([[0.0, 2.0]]))[0]).astype(int)
    assert tuple(img[r, c]) == DEFAULT_COLORS.box


def test_track_picture_synthetic() -> None:
    pic = track_picture(ring(), width=600)
    assert pic.shape[1] == 600 and pic.shape[2] == 3 and pic.dtype == np.uint8
    assert pic.shape[0] % 16 == 0
    open_pic = track_picture(straight(), width=480)
    assert open_pic.shape[1] == 480 and open_pic.shape[0] < 480  # follows the track's aspect


def test_track_picture_real_tracks() -> None:
    if not SHARED.is_dir():
        pytest.skip(f"{SHARED} is absent: the real DeepRacer tracks live in ../shared/tracks beside the repo")
    for path in sorted(SHARED.glob("*.npy")):
        route = np.load(path)
        track = SimpleNamespace(
            name=path.stem,
            center=route[:, 0:2],
            inner=route[:, 2:4],
            outer=route[:, 4:6],
            closed=bool(np.allclose(route[0], route[-1])),
        )
        pic = track_picture(track, width=400)
        road = np.all(np.abs(pic.astype(int) - np.array(DEFAULT_COLORS.road)) < 6, axis=2)
        # AWS Track, 69 m of 0.61 m road spread over the largest area, is the sparsest: 2.3% road
        assert road.mean() > 0.02, path.stem


def test_too_small_size_rejected() -> None:
    with pytest.raises(ValueError):
        TopDownRenderer(ring(), size=(10, 10))


def test_text_panel_moves_off_the_car_and_stays_put() -> None:
    """Issue 14: the readout covered the car in the top-left of the track."""
    renderer = TopDownRenderer(ring(), size=(640, 480))
    lines = ["a model on a track", "lap 1/3   3.95 s", "total 3.95 s   progress 14.2%", "speed 1 m/s"]
    fr = renderer.frame
    centre = ring().center
    px = fr.to_px(centre)
    top_left = centre[int(np.argmin(px[:, 0] + px[:, 1]))]  # the track point nearest the top-left corner
    img = renderer.render(*top_left, 0.0, text_lines=lines)
    corner, (x0, y0) = renderer._place_panel(img, lines, tuple(top_left))
    assert corner == "bottom-left" and (x0, y0) != (0, 0)  # the first corner clear of the car
    c, r = np.round(renderer.car_px(tuple(top_left))).astype(int)
    plain = renderer.render(*top_left, 0.0)
    np.testing.assert_array_equal(img[r - 3 : r + 4, c - 3 : c + 4], plain[r - 3 : r + 4, c - 3 : c + 4])
    # the car driving on (round the right of the track) leaves the panel where it is
    right = centre[int(np.argmax(px[:, 0]))]
    assert renderer._place_panel(img, lines, tuple(right))[0] == "bottom-left"
    # a camera inset never lands on the panel
    frame = np.zeros((120, 160), np.uint8)
    both = renderer.render(*top_left, 0.0, camera_frame=frame, text_lines=lines)
    corner, (px0, py0) = renderer._place_panel(both, lines, tuple(top_left))
    assert not (both[py0 + 2 : py0 + 20, px0 + 2 : px0 + 20] == 0).all()


def test_bottom_reserve_keeps_the_panel_off_the_bottom_edge() -> None:
    renderer = TopDownRenderer(ring(), size=(640, 480))
    renderer.bottom_reserve = 40
    lines = ["one", "two"]
    centre = ring().center
    px = renderer.frame.to_px(centre)
    renderer._panel_corner = "bottom-left"
    far = centre[int(np.argmin(px[:, 0] + px[:, 1]))]  # top-left: the bottom-left corner is clear
    corner, (_, y0) = renderer._place_panel(renderer.background.copy(), lines, tuple(far))
    assert corner == "bottom-left"
    height = renderer.background.shape[0]
    assert y0 + 40 <= height - 40
