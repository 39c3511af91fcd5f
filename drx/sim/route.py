"""DeepRacer's route format: validation and quirk fixing.

A route is an ``(N, 6)`` float array ``center_x, center_y, inner_x, inner_y,
outer_x, outer_y`` in metres (``../shared/tracks/README.md``). Real routes have
quirks: repeated centre points, loops left open by a few centimetres, and
files whose inner and outer columns are swapped.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from drx.errors import DrxError
from drx.sim.geometry import signed_area

NEARLY_CLOSED_FRACTION = 0.05  # a gap under 5% of the length (and ~2 segments) is a loop to close
# Beyond any DeepRacer track (the real routes in ../shared/tracks span at most 18.5 m and 354 rows):
# the bounds keep an import's memory small (the 1 cm road raster of an 80 m square is 64 MB).
MAX_EXTENT = 80.0  # [m] the route's bounding box, each side
MAX_ROWS = 10_000


def read_route_file(path: Path) -> np.ndarray:
    """A ``.npy`` route, its header checked (dtype, shape, rows) before any data is read; no pickles.

    :raises DrxError: unreadable, not an array of real numbers, not (N, 6), or too many rows.
    """
    path = Path(path)
    try:
        with open(path, "rb") as f:
            version = np.lib.format.read_magic(f)
            if version == (1, 0):
                shape, _fortran, dtype = np.lib.format.read_array_header_1_0(f)
            else:  # 2.0 (and 3.0, whose header is read the same way)
                shape, _fortran, dtype = np.lib.format.read_array_header_2_0(f)
    except (OSError, ValueError, EOFError, SyntaxError) as exc:
        raise DrxError(f"Track file {path.name} is not a readable NumPy .npy array ({exc}).") from None
    _check_dtype(dtype, path.stem)
    _check_shape(tuple(shape), path.stem)
    try:
        return np.load(path, allow_pickle=False)
    except (OSError, ValueError, EOFError) as exc:
        raise DrxError(f"Track file {path.name} is damaged ({exc}).") from None


def _check_dtype(dtype: np.dtype, name: str) -> None:
    if dtype.kind not in "fiu":
        kind = {"c": "complex numbers", "U": "strings", "S": "bytes", "O": "Python objects", "b": "booleans"}
        raise DrxError(
            f"Track {name!r} holds {kind.get(dtype.kind, f'{dtype} values')}; a DeepRacer route holds real "
            "coordinates in metres (float)."
        )


def _check_shape(shape: tuple[int, ...], name: str) -> None:
    if len(shape) != 2 or shape[1] != 6:
        raise DrxError(
            f"Track {name!r} has shape {shape}; a DeepRacer route is (N, 6): "
            "center_x, center_y, inner_x, inner_y, outer_x, outer_y."
        )
    if shape[0] > MAX_ROWS:
        raise DrxError(
            f"Track {name!r} has {shape[0]:,} rows; DeepRacer routes have a few hundred (drx takes up to "
            f"{MAX_ROWS:,}): resample it."
        )


def _check_extent(arr: np.ndarray, name: str) -> None:
    """Refuse a route larger than any DeepRacer track, naming the likely unit mistake."""
    with np.errstate(over="ignore", invalid="ignore"):
        xs, ys = arr[:, 0::2], arr[:, 1::2]
        span = max(float(xs.max()) - float(xs.min()), float(ys.max()) - float(ys.min()))
    if span <= MAX_EXTENT:
        return
    if span <= MAX_EXTENT * 100:
        cause = "the coordinates look like centimetres: divide them by 100"
    elif span <= MAX_EXTENT * 1000:
        cause = "the coordinates look like millimetres: divide them by 1000"
    else:
        cause = "the coordinates are not in metres"
    shown = f"{span:,.0f} m" if span < 1e12 else f"{span:.3g} m"
    raise DrxError(
        f"Track {name!r} spans {shown}; no DeepRacer track is larger than {MAX_EXTENT:g} m, so {cause}."
    )


def parse_route(route: Any, name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool, list[str]]:
    """Validate a route and fix its quirks.

    Fixes: a nearly closed loop gets its closing row; swapped inner/outer borders are put
    back. Repeated centre points are kept (so waypoint indices match DeepRacer's); the track
    skips their zero-length segments.
    :return: ``(center, inner, outer, closed, notes)``, notes saying what was fixed.
    :raises DrxError: on a malformed array.
    """
    raw = route if isinstance(route, np.ndarray) else np.asarray(route)
    _check_dtype(raw.dtype, name)
    _check_shape(raw.shape, name)
    arr = raw.astype(np.float64, copy=False)
    if len(arr) < 3:
        raise DrxError(f"Track {name!r} has {len(arr)} rows; a route needs at least 3.")
    if not np.all(np.isfinite(arr)):
        raise DrxError(f"Track {name!r} contains NaN or infinite coordinates.")
    _check_extent(arr, name)
    notes: list[str] = []
    seg = np.linalg.norm(np.diff(arr[:, 0:2], axis=0), axis=1)
    length = float(seg.sum())
    gap = float(np.linalg.norm(arr[0, 0:2] - arr[-1, 0:2]))
    closed = bool(np.all(arr[0] == arr[-1]))
    if not closed and gap < 1e-9:
        arr = arr.copy()
        arr[-1] = arr[0]  # the centre closes; the borders differ by a rounding error
        closed = True
    elif not closed and gap < NEARLY_CLOSED_FRACTION * length and gap <= 2.0 * float(seg.max()):
        arr = np.vstack([arr, arr[:1]])
        closed = True
        notes.append(f"The loop was open by {gap:.3f} m; added a closing row equal to row 0.")
    repeats = np.flatnonzero(seg < 1e-9)
    if len(repeats):
        rows = ", ".join(str(int(i) + 1) for i in repeats)
        notes.append(
            f"Centre row(s) {rows} repeat the previous point; kept so waypoint indices match "
            "DeepRacer, their zero-length segments are skipped."
        )
    inner, outer = arr[:, 2:4], arr[:, 4:6]
    if closed and abs(signed_area(inner[:-1])) > abs(signed_area(outer[:-1])):
        inner, outer = outer, inner
        notes.append("The inner and outer borders were swapped; put the inside border first.")
    return arr[:, 0:2], inner, outer, closed, notes
