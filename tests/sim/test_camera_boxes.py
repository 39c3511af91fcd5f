"""Box drawing: the static-geometry cache never changes a frame; the stereo eyes share one projection."""

from __future__ import annotations

import math

import numpy as np

from drx.sim.camera import CameraConfig, CameraRenderer

from .test_camera import stadium

BOXES = [(0.0, 0.1, 0.3, 0.3, 0.4, 0.25), (0.6, -0.3, 0.0, 0.3, 0.4, 0.25)]


def test_cached_geometry_draws_the_same_frames() -> None:
    track = stadium()
    fresh = CameraRenderer(track)
    first = fresh.render_stereo(-1.0, 0.0, 0.05, boxes=BOXES).copy()
    used = CameraRenderer(track)
    for k in range(100):  # more boxes than the cache keeps, some moving every frame
        used.render_stereo(-1.0, 0.0, 0.05, boxes=[(0.01 * k, 0.0, 0.1 * k, 0.3, 0.4, 0.25), *BOXES])
    np.testing.assert_array_equal(used.render_stereo(-1.0, 0.0, 0.05, boxes=BOXES), first)
    np.testing.assert_array_equal(
        used.render(-1.0, 0.0, 0.05, boxes=BOXES), fresh.render(-1.0, 0.0, 0.05, boxes=BOXES)
    )


def test_each_stereo_eye_is_the_mono_camera_moved_sideways() -> None:
    """Boxes are projected once for both eyes; each eye matches a mono camera at its place (to
    a pixel's anti-aliasing at the box's edges)."""
    track = stadium()
    base = 0.06
    stereo = CameraRenderer(track, CameraConfig(stereo_baseline=base)).render_stereo(
        -1.0, 0.0, 0.0, boxes=BOXES
    )
    mono = CameraRenderer(track, CameraConfig(stereo_baseline=0.0))
    for channel, side in ((0, 1.0), (1, -1.0)):
        # the eye sits base/2 to the car's left (heading 0: +y) for the left camera
        eye = mono.render(-1.0, side * base / 2, 0.0, boxes=BOXES)
        diff = np.abs(stereo[:, :, channel].astype(int) - eye.astype(int))
        assert (diff > 40).mean() < 0.01, channel
        assert math.isclose(float(diff.mean()), 0.0, abs_tol=1.0)
