"""The README table of ../shared/tracks, as test data, and loaders of those routes as drx ships them
(``drx/tracks/deepracer``, copied from ../shared/tracks by tools/sync_deepracer_routes.py)."""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np

from drx.sim.catalogue import SHIPPED_FOLDERS
from drx.sim.track import Track

# name: (rows, loop, direction, centre-line length [m], road width [m])
TRACKS = {
    "reinvent_base": (119, True, "ccw", 17.709, 0.76),
    "reInvent2019_wide_cw": (57, True, "cw", 16.598, 1.06),
    "reInvent2019_track": (155, True, "ccw", 23.118, 1.07),
    "2022_reinvent_champ": (112, True, "ccw", 33.275, 0.94),
    "Spain_track": (259, True, "cw", 59.998, 0.91),
    "Oval_track": (102, True, "ccw", 19.550, 0.61),
    "Bowtie_track": (163, True, "ccw", 17.428, 0.61),
    "Canada_Training": (203, True, "ccw", 21.743, 0.66),
    "China_eval_track": (122, True, "ccw", 18.141, 0.66),
    "Straight_track": (22, False, "-", 5.707, 0.61),
}
NAMES = sorted(TRACKS)

SHARED = SHIPPED_FOLDERS["deepracer"]  # the routes of ../shared/tracks, shipped in the package


def shared_path(name: str) -> Path:
    """A real DeepRacer route, as drx ships it."""
    path = SHARED / f"{name}.npy"
    assert path.is_file(), f"{path} is not shipped; run tools/sync_deepracer_routes.py"
    return path


@functools.cache
def _load(name: str) -> Track:
    track, _ = Track.from_route(np.load(SHARED / f"{name}.npy"), name)
    return track


def shared_track(name: str) -> Track:
    """The parsed track (cached across tests, parsing Spain takes 0.3 s)."""
    shared_path(name)
    return _load(name)
