"""DeepRacer's route format: validation and quirk fixing.

A route is an ``(N, 6)`` float array ``center_x, center_y, inner_x, inner_y,
outer_x, outer_y`` in metres (``../shared/tracks/README.md``). Real routes have
quirks: repeated centre points, loops left open by a few centimetres, and
files whose inner and outer columns are swapped.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from drx.errors import DrxError
from drx.sim.geometry import signed_area

NEARLY_CLOSED_FRACTION = 0.05  # a gap under 5% of the length (and ~2 segments) is a loop to close


def parse_route(route: Any, name: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool, list[str]]:
    """Validate a route and fix its quirks.

    Fixes: a nearly closed loop gets its closing row; swapped inner/outer borders are put
    back. Repeated centre points are kept (so waypoint indices match DeepRacer's); the track
    skips their zero-length segments.
    :return: ``(center, inner, outer, closed, notes)``, notes saying what was fixed.
    :raises DrxError: on a malformed array.
    """
    try:
        arr = np.asarray(route, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise DrxError(f"Track {name!r} is not a numeric array: {exc}.") from None
    if arr.ndim != 2 or arr.shape[1] != 6:
        raise DrxError(
            f"Track {name!r} has shape {arr.shape}; a DeepRacer route is (N, 6): "
            "center_x, center_y, inner_x, inner_y, outer_x, outer_y."
        )
    if len(arr) < 3:
        raise DrxError(f"Track {name!r} has {len(arr)} rows; a route needs at least 3.")
    if not np.all(np.isfinite(arr)):
        raise DrxError(f"Track {name!r} contains NaN or infinite coordinates.")
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
