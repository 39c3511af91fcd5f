"""The front camera: geometry of the pinhole model, and frames that show the road where it is."""

from __future__ import annotations

import math
import time
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import cv2
import numpy as np
import pytest

from drx.sim.camera import CameraConfig, CameraRenderer
from drx.sim.render import DEFAULT_COLORS, to_gray

SHARED = Path(__file__).resolve().parents[2].parent / "shared" / "tracks"
BORDER_MIN = 160  # the white border's peak is brighter than this even far away (softened by mipmaps)


def stadium(straight: float = 6.0, radius: float = 2.0, width: float = 0.76, step: float = 0.1) -> Any:
    """A synthetic CCW loop: two straights along x joined by half circles; row 0 mid-straight."""
    pts = []
    n_s = int(straight / step)
    for i in range(n_s):
        pts.append((i * step, 0.0))
    n_c = int(math.pi * radius / step)
    for i in range(n_c):
        a = -math.pi / 2 + math.pi * i / n_c
        pts.append((straight + radius * math.cos(a), radius + radius * math.sin(a)))
    for i in range(n_s):
        pts.append((straight - i * step, 2 * radius))
    for i in range(n_c):
        a = math.pi / 2 + math.pi * i / n_c
        pts.append((radius * math.cos(a), radius + radius * math.sin(a)))
    center = np.array(pts + [pts[0]], dtype=np.float64) - np.array([straight / 2, 0.0])
    tangent = np.gradient(center, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    left = np.column_stack([-tangent[:, 1], tangent[:, 0]])
    inner = center + left * width / 2
    outer = center - left * width / 2
    inner[-1], outer[-1] = inner[0], outer[0]
    return SimpleNamespace(name="stadium", center=center, inner=inner, outer=outer, closed=True)


def shared_track(name: str) -> Any:
    """A real DeepRacer route from ../shared/tracks (skips when absent), as a drx Track when available."""
    path = SHARED / f"{name}.npy"
    if not path.is_file():
        pytest.skip(f"{path} is absent: the real DeepRacer tracks live in ../shared/tracks beside the repo")
    route = np.load(path)
    try:
        from drx.sim.track import Track
    except ImportError:  # the track module is optional to the renderer: it only needs these attributes
        closed = bool(np.allclose(route[0], route[-1]))
        return SimpleNamespace(name=name, center=route[:, 0:2], inner=route[:, 2:4], outer=route[:, 4:6],
                               closed=closed)
    return Track.from_route(route, name)[0]


@pytest.fixture(scope="module")
def loop_camera() -> CameraRenderer:
    return CameraRenderer(stadium())


def border_columns(row: np.ndarray) -> tuple[float, float]:
    """Columns of the white border paint at the left and right edges of the road on one image row.

    The road's edges are where road-grey pixels end; the border is the brightest pixel just beyond.
    """
    road = np.flatnonzero(np.abs(row.astype(int) - to_gray(DEFAULT_COLORS.road)) < 10)
    assert len(road) > 10, f"no road on row: {row.tolist()}"
    lo, hi = int(road.min()), int(road.max())
    left_win, right_win = row[max(0, lo - 8) : lo + 1], row[hi : hi + 9]
    assert left_win.max() > BORDER_MIN and right_win.max() > BORDER_MIN, f"no border paint: {row.tolist()}"
    left = max(0, lo - 8) + _peak(left_win)
    right = hi + _peak(right_win)
    return left, right


def _peak(values: np.ndarray) -> float:
    """Sub-pixel position of the brightest run: the centroid of values above the midpoint."""
    v = values.astype(float)
    w = np.clip(v - (v.max() + v.min()) / 2, 0, None)
    return float((w * np.arange(len(v))).sum() / w.sum())


def test_config_geometry() -> None:
    cfg = CameraConfig()
    assert (cfg.width, cfg.height) == (160, 120)
    assert cfg.focal == pytest.approx(80 / math.tan(0.565))
    assert cfg.principal_point == (79.5, 59.5)
    # pitched 15 deg down: the horizon is f tan(15 deg) above the image centre, about row 25.7
    assert cfg.horizon_row == pytest.approx(59.5 - cfg.focal * math.tan(math.radians(15)))
    assert cfg.first_ground_row == 26
    assert math.degrees(cfg.vfov) == pytest.approx(2 * math.degrees(math.atan(60 / cfg.focal)))
    with pytest.raises(ValueError):
        CameraConfig(mount_height=0.0)
    with pytest.raises(ValueError):
        CameraConfig(pitch=math.pi / 2)


def test_other_pitches() -> None:
    """Looking up (horizon below the frame) gives all sky; looking steeply down gives no sky."""
    track = stadium()
    up = CameraRenderer(track, CameraConfig(pitch=-0.8)).render(-1.0, 0.0, 0.0)
    assert up.shape == (120, 160) and (up.max(axis=1) == up.min(axis=1)).all()
    down_cam = CameraRenderer(track, CameraConfig(pitch=math.radians(60)))
    assert down_cam.config.first_ground_row == 0
    down = down_cam.render(-1.0, 0.0, 0.0)
    assert np.abs(down[0].astype(int) - to_gray(DEFAULT_COLORS.road)).min() < 8  # road at the top row


def test_frame_dtype_shape_and_out(loop_camera: CameraRenderer) -> None:
    img = loop_camera.render(-0.14, 0.0, 0.0)
    assert img.shape == (120, 160) and img.dtype == np.uint8
    out = np.zeros((120, 160), np.uint8)
    again = loop_camera.render(-0.14, 0.0, 0.0, out=out)
    assert again is out
    np.testing.assert_array_equal(out, img)
    assert loop_camera.render(-0.14, 0.0, 0.0) is not img  # a new array each time without ``out``
    with pytest.raises(ValueError):
        loop_camera.render(-0.14, 0.0, 0.0, out=np.zeros((120, 160), np.float32))
    with pytest.raises(ValueError):
        loop_camera.render(-0.14, 0.0, 0.0, out=np.zeros((160, 120), np.uint8))
    stereo_out = np.zeros((120, 160, 2), np.uint8)
    assert loop_camera.render_stereo(-0.14, 0.0, 0.0, out=stereo_out) is stereo_out
    with pytest.raises(ValueError):
        loop_camera.render_stereo(-0.14, 0.0, 0.0, out=np.zeros((120, 160), np.uint8))


def test_sky_above_horizon_ground_below(loop_camera: CameraRenderer) -> None:
    cfg = loop_camera.config
    img = loop_camera.render(-0.14, 0.0, 0.0)
    first = cfg.first_ground_row
    sky = img[:first].astype(int)
    assert (sky.max(axis=1) == sky.min(axis=1)).all(), "the sky is a plain vertical gradient"
    sky_gray = (to_gray(DEFAULT_COLORS.sky_top), to_gray(DEFAULT_COLORS.sky_horizon))
    assert sky.min() >= min(sky_gray) - 1 and sky.max() <= max(sky_gray) + 1
    # just below the horizon the ground is so far away it reads as the flat ground grey
    ground = to_gray(DEFAULT_COLORS.ground)
    assert abs(float(img[first].mean()) - ground) < 12
    # and the road fills the bottom centre
    bottom = int(img[-1, 80])
    assert abs(bottom - to_gray(DEFAULT_COLORS.road)) < 12 or bottom > 150  # road or centre paint


def test_start_line_projects_to_the_predicted_row() -> None:
    """A line across the road D ahead of the camera shows at row cy + f tan(atan(h / D) - pitch)."""
    track = stadium()
    cam = CameraRenderer(track)
    cfg = cam.config
    for dist in (0.4, 0.7, 1.2):
        # rear axle so that the camera stands ``dist`` before the start line (x = -3 + ... is row 0)
        x0 = float(track.center[0, 0])
        img = cam.render(x0 - dist - cfg.mount_forward, 0.0, 0.0)
        below_axis = math.atan(cfg.mount_height / dist) - cfg.pitch
        expected = cfg.principal_point[1] + cfg.focal * math.tan(below_axis)
        # the centre column is on the dashed centre line; look a bit to the side, on plain road,
        # within 5 rows of the prediction (further up, the far side of the loop shows)
        lo = max(cfg.first_ground_row, int(expected) - 5)
        column = img[lo : int(expected) + 6, 60].astype(float)
        rows = np.flatnonzero(column > 225) + lo
        assert len(rows), f"start line not seen at {dist} m"
        assert abs(rows.mean() - expected) < 1.0, (dist, rows, expected)


def test_borders_symmetric_on_synthetic_straight(loop_camera: CameraRenderer) -> None:
    img = loop_camera.render(-1.0, 0.0, 0.0)
    for row in (32, 40, 48):
        left, right = border_columns(img[row])
        assert (left + right) / 2 == pytest.approx(79.5, abs=1.0), (row, left, right)


@pytest.mark.parametrize("name", ["Straight_track", "reinvent_base"])
def test_borders_symmetric_on_real_straight(name: str) -> None:
    track = shared_track(name)
    cam = CameraRenderer(track)
    center = np.asarray(track.center)
    # reinvent_base starts on its long straight; Straight_track is one
    a, b = center[1], center[2]
    yaw = math.atan2(b[1] - a[1], b[0] - a[0])
    img = cam.render(float(a[0]), float(a[1]), yaw)
    for row in (34, 42):
        left, right = border_columns(img[row])
        assert (left + right) / 2 == pytest.approx(79.5, abs=2.0), (name, row, left, right)


def road_middle(img: np.ndarray, row: int = 38) -> float:
    """Column midway between the road's edges on one image row."""
    left, right = border_columns(img[row])
    return (left + right) / 2


def test_turning_left_moves_the_road_right(loop_camera: CameraRenderer) -> None:
    straight = road_middle(loop_camera.render(-1.0, 0.0, 0.0))
    left = road_middle(loop_camera.render(-1.0, 0.0, math.radians(12)))
    right = road_middle(loop_camera.render(-1.0, 0.0, math.radians(-12)))
    # a 12 deg turn moves the far road by about f tan(12 deg) = 27 px
    assert left > straight + 15
    assert right < straight - 15
    assert left - straight == pytest.approx(straight - right, abs=1.5)
    # moving left on the road (same heading) also moves the road right
    assert road_middle(loop_camera.render(-1.0, 0.15, 0.0)) > straight + 5


def test_stereo_channels(loop_camera: CameraRenderer) -> None:
    img = loop_camera.render_stereo(-1.0, 0.0, 0.0)
    assert img.shape == (120, 160, 2) and img.dtype == np.uint8
    left, right = img[:, :, 0], img[:, :, 1]
    diff = np.abs(left.astype(int) - right.astype(int))
    assert diff.max() > 50, "the two cameras see slightly different frames"
    assert diff.mean() < 20, "but the same scene"
    # the left camera sits left, so the road appears further right in its image
    l_left, l_right = border_columns(left[40])
    r_left, r_right = border_columns(right[40])
    assert (l_left + l_right) / 2 > (r_left + r_right) / 2 + 1
    # with a zero baseline both equal the mono frame
    mono_cam = CameraRenderer(stadium(), CameraConfig(stereo_baseline=0.0))
    both = mono_cam.render_stereo(-1.0, 0.0, 0.0)
    np.testing.assert_array_equal(both[:, :, 0], mono_cam.render(-1.0, 0.0, 0.0))
    np.testing.assert_array_equal(both[:, :, 1], both[:, :, 0])


def test_boxes_drawn_ahead_not_behind(loop_camera: CameraRenderer) -> None:
    plain = loop_camera.render(-1.0, 0.0, 0.0)
    ahead = loop_camera.render(-1.0, 0.0, 0.0, boxes=[(0.0, 0.0, 0.0, 0.3, 0.3, 0.25)])
    changed = np.abs(ahead.astype(int) - plain.astype(int)) > 20
    rows, cols = np.nonzero(changed)
    assert len(rows) > 200
    assert abs(cols.mean() - 79.5) < 5, "a box straight ahead is drawn in the middle"
    assert rows.min() < loop_camera.config.horizon_row, "taller than the camera: it rises above the horizon"
    behind = loop_camera.render(-1.0, 0.0, 0.0, boxes=[(-2.0, 0.0, 0.0, 0.3, 0.3)])
    np.testing.assert_array_equal(behind, plain)
    # a box right at the camera (partly behind it) is clipped, not an error
    loop_camera.render(-1.0, 0.0, 0.0, boxes=[(-0.85, 0.0, 0.3, 0.3, 0.3)])
    # boxes may also come as an (k, 5|6) array, or none at all
    as_array = loop_camera.render(-1.0, 0.0, 0.0, boxes=np.array([[0.0, 0.0, 0.0, 0.3, 0.3, 0.25]]))
    np.testing.assert_array_equal(as_array, ahead)
    np.testing.assert_array_equal(loop_camera.render(-1.0, 0.0, 0.0, boxes=np.empty((0, 5))), plain)
    stereo = loop_camera.render_stereo(-1.0, 0.0, 0.0, boxes=[(0.0, 0.0, 0.0, 0.3, 0.3)])
    assert (np.abs(stereo[:, :, 0].astype(int) - plain) > 20).sum() > 200


def test_renderers_share_the_texture() -> None:
    track = stadium()
    a, b = CameraRenderer(track), CameraRenderer(stadium())
    assert a._levels[0] is b._levels[0]
    assert not a._levels[0].flags.writeable
    c = CameraRenderer(track, CameraConfig(texture_resolution=0.01))
    assert c._levels[0] is not a._levels[0]
    np.testing.assert_array_equal(a.render(-1.0, 0.0, 0.0), b.render(-1.0, 0.0, 0.0))


def test_large_track_texture_is_capped() -> None:
    track = stadium(straight=60.0, radius=10.0)
    cam = CameraRenderer(track, CameraConfig(max_texture_pixels=2_000_000))
    assert cam.frame.width * cam.frame.height <= 2_000_000 * 1.01
    assert cam.frame.res > 0.01
    img = cam.render(-1.0, 0.0, 0.0)
    left, right = border_columns(img[40])
    assert (left + right) / 2 == pytest.approx(79.5, abs=1.5)


def test_every_shared_track_renders() -> None:
    if not SHARED.is_dir():
        pytest.skip(f"{SHARED} is absent")
    for path in sorted(SHARED.glob("*.npy")):
        track = shared_track(path.stem)
        cam = CameraRenderer(track)
        c = np.asarray(track.center)
        yaw = math.atan2(c[1, 1] - c[0, 1], c[1, 0] - c[0, 0])
        img = cam.render(float(c[0, 0]), float(c[0, 1]), yaw)
        road = np.abs(img[60:].astype(int) - to_gray(DEFAULT_COLORS.road)) < 8
        assert road.mean() > 0.3, f"{path.stem}: a car on the start line sees road ahead"


def test_render_speed(loop_camera: CameraRenderer) -> None:
    """Loose bound only (CI machines vary); benchmarks/camera_speed.py reports the real figure."""
    threads = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        out = np.empty((120, 160), np.uint8)
        n = 300
        start = time.perf_counter()
        for i in range(n):
            loop_camera.render(-1.0 + i * 0.01, 0.01 * (i % 7), 0.02 * (i % 5), out=out)
        per_frame = (time.perf_counter() - start) / n
    finally:
        cv2.setNumThreads(threads)
    assert per_frame < 1e-3, f"{per_frame * 1e6:.0f} us per frame"
