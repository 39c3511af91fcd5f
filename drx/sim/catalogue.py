"""The track catalogue: every track a name can mean, and the one place a name is resolved.

Three sources of tracks:

* ``deepracer``: DeepRacer's own routes, shipped in the package (``drx/tracks/deepracer/``, upstream
  file names, see its ``NOTICE.md``), named by their route id and, where a public source names
  them, the console's display name (:mod:`drx.sim.track_names`);
* ``drx``: drx's own tracks (``drx/tracks/drx/``, made by ``tracks/design.py``);
* ``imported``: the routes a user imported (``drx track import``); the registry lists them, and
  the simulator, which knows nothing of the registry, finds them in ``$DRX_HOME/tracks``.

:func:`resolve` turns what a user typed into one :class:`TrackEntry`: the exact route id first,
then the route id in any case, then the display name (in any case, with its direction or, when
only one track has that name, without it). With a direction (``cw``/``ccw``, ``drx model create
--direction``), a two-way track resolves to its route for that direction (:func:`variant`). An
unknown name is one sentence with up to three near matches; a DeepRacer route drx does not ship
says how to import it. This module reads no route file: listing and resolving names costs no
NumPy (whether a one-way track must be driven reversed is the services' question, which reads
the route's direction: :func:`drx.services.tracks.find_directed`).
"""

from __future__ import annotations

import difflib
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from drx.errors import DrxError, NotFoundError
from drx.sim.track_names import NO_PUBLIC_NAME, display_name, known_route_ids, name_key

PACKAGE_TRACKS = Path(__file__).resolve().parents[1] / "tracks"
SHIPPED_FOLDERS = {"deepracer": PACKAGE_TRACKS / "deepracer", "drx": PACKAGE_TRACKS / "drx"}
SOURCES = ("deepracer", "drx", "imported")
SOURCE_LABELS = {"deepracer": "DeepRacer", "drx": "drx", "imported": "imported", "file": "file"}
NEAR_MATCHES = 3
DIRECTION_SUFFIXES = ("_cw", "_ccw")  # a two-way track's routes: <id>_cw, <id>_ccw


@dataclass(frozen=True)
class TrackEntry:
    """A track the catalogue knows.

    :param name: its canonical name: DeepRacer's route id (``reInvent2019_wide_cw``), drx's track
        name, or the name it was imported under. Models and evaluations store this name.
    :param source: ``deepracer``, ``drx`` or ``imported`` (:data:`SOURCES`).
    :param path: its route file.
    :param display_name: the console's name (``A to Z Speedway (clockwise)``), ``None`` if none.
    """

    name: str
    source: str
    path: Path
    display_name: str | None = None

    @property
    def label(self) -> str:
        """``name`` with the display name: ``reInvent2019_wide_cw (A to Z Speedway (clockwise))``."""
        return f"{self.name} ({self.display_name})" if self.display_name else self.name

    @property
    def display_text(self) -> str:
        """The display name as a table shows it ("no public display name" for an unnamed DeepRacer
        route, ``-`` for drx's and imported tracks without one)."""
        if self.display_name:
            return self.display_name
        return NO_PUBLIC_NAME if self.source == "deepracer" else "-"


def shipped_tracks() -> list[TrackEntry]:
    """The tracks in the package: DeepRacer's (by display name), then drx's own (by name)."""
    out = []
    for source, folder in SHIPPED_FOLDERS.items():
        entries = [
            TrackEntry(p.stem, source, p, display_name(p.stem) if source == "deepracer" else None)
            for p in folder.glob("*.npy")
        ]
        out += sorted(entries, key=sort_key)
    return out


def sort_key(entry: TrackEntry) -> tuple[str, str]:
    """Order within a source: by display name where there is one (as the console lists tracks)."""
    return ((entry.display_name or entry.name).lower(), entry.name.lower())


def imported_entry(name: str, path: Path, source_stem: str | None = None) -> TrackEntry:
    """An imported track: its display name is the one of its name's route id, else of the file it
    was imported from (``Austin.npy`` imported as ``hills`` is still American Hills Speedway)."""
    named = display_name(name) or (display_name(source_stem) if source_stem else None)
    return TrackEntry(name, "imported", Path(path), named)


def imported_files(folder: Path) -> list[TrackEntry]:
    """Imported tracks as the simulator finds them: the routes in ``$DRX_HOME/tracks``."""
    if not folder.is_dir():
        return []
    return [imported_entry(p.stem, p) for p in sorted(folder.glob("*.npy"))]


def find(name: str, entries: Sequence[TrackEntry], direction: str | None = None) -> TrackEntry | None:
    """The entry ``name`` means (see the module docstring), or ``None``.

    :param direction: ``cw`` or ``ccw`` (already parsed) to drive the track that way: a display
        name without its direction then means that direction's route, and a track with a route for
        that direction (its ``_cw``/``_ccw`` variant, :func:`variant`) resolves to it, whichever of
        its routes was named. ``None``: the route named.
    :raises DrxError: a display name given without its direction fits several tracks.
    """
    found = _named(name, entries, direction)
    if found is None or direction is None:
        return found
    return variant(found, direction, entries)


def _named(name: str, entries: Sequence[TrackEntry], direction: str | None) -> TrackEntry | None:
    text = name.strip()
    for entry in entries:
        if entry.name == text:
            return entry
    low = text.lower()
    for entry in entries:
        if entry.name.lower() == low:
            return entry
    words, typed = name_key(text)
    if not words:
        return None
    named = [(e, name_key(e.display_name)) for e in entries if e.display_name]
    exact = [e for e, key in named if key == (words, typed or direction)]
    if exact:
        return exact[0]
    if typed is None:
        plain = [e for e, key in named if key == (words, None)]  # a one-way track, named without direction
        if plain:
            return plain[0]
        same = [e for e, key in named if key[0] == words]
        if len(same) == 1:
            return same[0]
        if same:
            options = ", ".join(repr(e.display_name) for e in same)
            raise DrxError(f"Track name {name!r} fits several tracks ({options}); give one of those names.")
    return None


def variant(entry: TrackEntry, direction: str, entries: Sequence[TrackEntry]) -> TrackEntry:
    """The route of ``entry``'s track for ``direction``: ``<base>_cw`` or ``<base>_ccw`` when the
    catalogue has it (``reInvent2019_wide`` and ``reInvent2019_wide_ccw`` give
    ``reInvent2019_wide_cw`` for ``cw``), as the console turns a track and its direction into the
    route it drives (deepracer-simapp ``bundle/markov/boto/s3/files/yaml_file.py``); else ``entry``
    itself (a one-way track, which the trainer then drives reversed where the direction differs).
    """
    base = entry.name
    for suffix in DIRECTION_SUFFIXES:
        if base.endswith(suffix):
            base = base[: -len(suffix)]
            break
    wanted = f"{base}_{direction}"
    for other in entries:
        if other.name == wanted:
            return other
    return entry


def resolve(name: str, entries: Sequence[TrackEntry], direction: str | None = None) -> TrackEntry:
    """The entry ``name`` means, in ``direction`` when one is given (see :func:`find`).

    :raises NotFoundError: no track has that name; the sentence gives near matches, or says how to
        import a DeepRacer route drx does not ship.
    """
    found = find(name, entries, direction)
    if found is None:
        raise unknown_track(name, entries)
    return found


def unknown_track(name: str, entries: Sequence[TrackEntry]) -> NotFoundError:
    """The error for a track name nothing in ``entries`` has (one sentence)."""
    route = _unshipped_route(name)
    if route is not None:
        named = display_name(route)
        what = f"DeepRacer's {named} (route {route})" if named else f"DeepRacer's route {route}"
        return NotFoundError(
            f"Track {name!r} is {what}, which drx does not ship; import its route file with "
            f"`drx track import {route}.npy`."
        )
    near = near_matches(name, entries)
    hint = f"did you mean {', '.join(near)}? " if near else ""
    return NotFoundError(f"No track named {name!r}; {hint}`drx track list` lists every track.")


def near_matches(name: str, entries: Sequence[TrackEntry], n: int = NEAR_MATCHES) -> list[str]:
    """Up to ``n`` tracks whose name or display name is close to ``name`` (quoted, as labels)."""
    low = name.strip().lower()
    keys: dict[str, TrackEntry] = {}
    for entry in entries:
        keys.setdefault(entry.name.lower(), entry)
        if entry.display_name:
            keys.setdefault(entry.display_name.lower(), entry)
    hits = [keys[k] for k in keys if low and len(low) >= 3 and low in k]
    hits += [keys[k] for k in difflib.get_close_matches(low, list(keys), n=2 * n, cutoff=0.6)]
    out: list[str] = []
    for entry in hits:
        label = repr(entry.name) + (f" ({entry.display_name})" if entry.display_name else "")
        if label not in out:
            out.append(label)
    return out[:n]


def _unshipped_route(name: str) -> str | None:
    """The route id of a DeepRacer route drx can name but does not ship, if ``name`` means one."""
    text = name.strip()
    ids = known_route_ids()
    for route in ids:
        if route.lower() == text.lower():
            return route
    key = name_key(text)
    if not key[0]:
        return None
    for route in ids:
        named = display_name(route)
        if named and name_key(named) == key:
            return route
    return None
