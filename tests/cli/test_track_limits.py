"""Crafted routes: centimetres, 1e300, ten million rows, complex numbers, strings; refused quickly."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

from drx.sim.route import MAX_EXTENT, MAX_ROWS
from drx.sim.track import load_track

from .helpers import fails_unchanged

OVAL = load_track("oval").to_route()


@pytest.mark.parametrize(
    "scale, said",
    [
        (100.0, "coordinates look like centimetres: divide them by 100"),
        (1000.0, "coordinates look like millimetres"),
        (1e300, "coordinates are not in metres"),
    ],
)
def test_a_route_larger_than_any_deepracer_track_is_refused(tmp_path: Path, scale: float, said: str) -> None:
    path = tmp_path / "big.npy"
    np.save(path, OVAL * scale)
    t0 = time.monotonic()
    err = fails_unchanged("track", "import", str(path), contains=(said, f"larger than {MAX_EXTENT:g} m"))
    assert time.monotonic() - t0 < 5
    assert " spans " in err


def test_ten_million_rows_are_refused_before_reading_them(tmp_path: Path) -> None:
    """The header says 10 million rows: refused without reading (or even having) the 480 MB of data."""
    path = tmp_path / "long.npy"
    with open(path, "wb") as f:
        np.lib.format.write_array_header_1_0(
            f, {"descr": "<f8", "fortran_order": False, "shape": (10_000_000, 6)}
        )
        f.write(b"\0" * 48)
    t0 = time.monotonic()
    fails_unchanged("track", "import", str(path), contains=("10,000,000 rows", f"{MAX_ROWS:,}"))
    assert time.monotonic() - t0 < 5


@pytest.mark.parametrize(
    "array, said",
    [
        (OVAL.astype(np.complex128), "complex numbers"),
        (OVAL.astype(str), "strings"),
        (OVAL > 0, "booleans"),
    ],
    ids=["complex", "strings", "bools"],
)
def test_routes_of_other_than_real_numbers_are_refused(tmp_path: Path, array: np.ndarray, said: str) -> None:
    path = tmp_path / "odd.npy"
    np.save(path, array)
    fails_unchanged("track", "import", str(path), contains=(said, "real coordinates"))


def test_integer_routes_are_still_accepted(tmp_path: Path) -> None:
    from drx.sim.track import Track

    track, _ = Track.from_route(np.round(OVAL * 10).astype(np.int64) / 10)
    assert track.length > 10
