"""Tracks: the catalogue (DeepRacer's routes and drx's own, shipped in the package, and the routes
users import), resolving a name once per command, listing, showing and importing.

The shipped tracks and the rules that turn a typed name into one track are
:mod:`drx.sim.catalogue`'s; this module adds the imported tracks from the registry. A command
resolves its ``--track`` once with :func:`find_track` and passes the :class:`TrackEntry` (and the
loaded :class:`~drx.sim.track.Track`) on; what models and evaluations store is the entry's
canonical ``name`` (the route id), so a track typed as "A to Z Speedway (clockwise)" is stored as
``reInvent2019_wide_cw``.

``drx track import`` reads any DeepRacer route, fixes its quirks (via
:meth:`drx.sim.track.Track.from_route`), writes the fixed route to
``$DRX_HOME/tracks/<name>.npy`` (where :func:`drx.sim.track.load_track` finds it) and registers it
in the ``tracks`` table; it refuses a name that a shipped track answers to.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

from drx.atomic import atomic_write, write_json_atomic
from drx.config import data_home
from drx.errors import DrxError, NameTakenError, SettingError, not_a_file
from drx.registry import quick
from drx.services.names import ITEM_NAME_RE, NAME_RULE, check_item_name
from drx.settings.episodes import OPEN, TrainingTrack, parse_direction
from drx.sim.catalogue import (
    SOURCE_LABELS,
    SOURCES,
    TrackEntry,
    find,
    imported_entry,
    resolve,
    shipped_tracks,
)
from drx.sim.track_names import name_key

if TYPE_CHECKING:  # NumPy, the track geometry and SQLAlchemy load in the functions that use them
    import numpy as np

    from drx.registry import TrackRow
    from drx.sim.track import Track

DEFAULT_TRACK = "oval"
SKEW_NOTE_RATIO = 1.05  # row-wise border distance this much above the true width => rows are skewed
FACTS_CACHE = "track-facts.json"  # in the data home's cache/: the shipped tracks' facts for listing
FACT_KEYS = {"length", "width", "width_min", "width_max", "direction", "closed", "n_waypoints"}


@dataclass
class TrackInfo:
    """A track's facts, as ``drx track list/show`` print them."""

    name: str
    source: str  # "deepracer", "drx", "imported" (or "file": a route file shown before import)
    path: str
    length: float  # [m]
    width: float  # [m] median road width
    direction: str  # ccw | cw | -
    closed: bool
    n_waypoints: int
    notes: list[str] = field(default_factory=list)
    created_at: datetime | None = None
    width_min: float | None = None
    width_max: float | None = None
    corners: list[dict[str, float]] = field(default_factory=list)
    display_name: str | None = None

    @property
    def turns(self) -> int:
        """Number of corners (only known once the geometry was loaded)."""
        return len(self.corners)

    @property
    def source_label(self) -> str:
        """The source as people read it: ``DeepRacer``, ``drx``, ``imported``."""
        return SOURCE_LABELS.get(self.source, self.source)

    def to_dict(self) -> dict[str, Any]:
        """JSON form."""
        return {
            "name": self.name,
            "display_name": self.display_name,
            "source": self.source,
            "path": self.path,
            "length": round(self.length, 4),
            "width": round(self.width, 4),
            "width_min": None if self.width_min is None else round(self.width_min, 4),
            "width_max": None if self.width_max is None else round(self.width_max, 4),
            "direction": self.direction,
            "closed": self.closed,
            "waypoints": self.n_waypoints,
            "turns": self.turns,
            "corners": self.corners,
            "notes": self.notes,
            "created_at": self.created_at.isoformat() if self.created_at else None,
        }


def _imported_entries() -> list[TrackEntry]:
    return [imported_entry(r.name, Path(r.path), _stem(r.source_path)) for r in _imported_rows()]


def _stem(path: str | None) -> str | None:
    return Path(path).stem if path else None


def catalogue() -> list[TrackEntry]:
    """Every track one can train on: DeepRacer's shipped routes, drx's own, then the imported ones."""
    return [*shipped_tracks(), *_imported_entries()]


def find_track(name: str) -> TrackEntry:
    """The track ``name`` means: a route id, a display name or an imported track's name (resolved
    once, by :func:`drx.sim.catalogue.resolve`).

    :raises NotFoundError: no such track; the sentence gives near matches.
    """
    return resolve(name, catalogue())


@dataclass(frozen=True)
class DirectedTrack:
    """A track resolved with the way to drive it.

    :param entry: the route (for a two-way track, its route in that direction).
    :param direction: ``cw`` or ``ccw`` as driven, ``-`` for an open track.
    :param reverse: the route is driven against the order of its waypoints (a one-way track asked
        for the other direction: :meth:`drx.sim.track.Track.reversed`, DeepRacer's ``REVERSE_DIR``).
    """

    entry: TrackEntry
    direction: str
    reverse: bool

    def training_track(self) -> TrainingTrack:
        """As a model stores it (:class:`drx.settings.episodes.TrainingTrack`)."""
        return TrainingTrack(self.entry.name, self.direction, self.reverse)


def route_direction(entry: TrackEntry) -> str:
    """The way a route's waypoints go round: ``cw``, ``ccw``, or ``-`` for an open track (the
    listing's cached facts of a shipped route, else measured: NumPy, a few milliseconds,
    :func:`drx.sim.track.route_facts`)."""
    facts = _cached_facts(entry, _facts_cache())[2] if entry.source != "imported" else None
    if facts is None:
        from drx.sim.track import route_facts

        facts = route_facts(entry.path)
    return str(facts["direction"])


def find_directed(name: str, direction: str | None = None) -> DirectedTrack:
    """The track ``name`` means driven ``direction`` (resolved once, :func:`drx.sim.catalogue.resolve`).

    A two-way track gives its ``_cw``/``_ccw`` route for the direction (``"A to Z Speedway"`` with
    ``cw`` is ``reInvent2019_wide_cw``); a track without a route for it is driven reversed.

    :param direction: ``cw``, ``ccw``, ``clockwise``, ``counter-clockwise`` (any case), or ``None``
        for the route's own way.
    :raises SettingError: an unknown direction, or a direction for an open track (it has none).
    :raises NotFoundError: no such track.
    """
    wanted = parse_direction(direction)
    entry = resolve(name, catalogue(), wanted)
    own = route_direction(entry)
    if wanted is None:
        return DirectedTrack(entry, own, False)
    if own == OPEN:
        raise SettingError(
            "Track {track!r} is open (its ends do not meet), so it has no direction; leave out {field}.",
            "direction",
            track=entry.name,
        )
    return DirectedTrack(entry, wanted, wanted != own)


def load_entry(entry: TrackEntry) -> Track:
    """The geometry of a catalogue entry (named by its canonical name)."""
    from drx.sim.track import load_track

    return load_track(entry.path)


def load_track_by_name(name: str) -> Track:
    """The geometry of the track ``name`` means (or of a ``.npy`` route file)."""
    from drx.sim.track import load_track

    if name.lower().endswith(".npy"):
        return load_track(name)
    return load_entry(find_track(name))


def _widths(track: Track) -> np.ndarray:
    import numpy as np

    from drx.sim.track import WIDTH_SAMPLES

    s = np.linspace(0.0, track.length, WIDTH_SAMPLES, endpoint=False)
    return np.array([track.width_at(float(v)) for v in s])


def describe(
    track: Track,
    source: str,
    path: Path | str,
    notes: list[str] | None = None,
    display_name: str | None = None,
) -> TrackInfo:
    """Facts of a loaded track (length, widths, direction, corners)."""
    import numpy as np

    widths = _widths(track)
    corners = [
        {
            "apex": round(float(c.apex_s), 3),
            "angle_deg": round(float(c.angle_deg), 1),
            "radius": round(float(c.radius), 3),
        }
        for c in track.corners()
    ]
    return TrackInfo(
        name=track.name,
        source=source,
        path=str(path),
        length=float(track.length),
        width=float(np.median(widths)),
        direction=track.direction,
        closed=bool(track.closed),
        n_waypoints=len(track.center),
        notes=list(notes if notes is not None else track.notes),
        width_min=float(widths.min()),
        width_max=float(widths.max()),
        corners=corners,
        display_name=display_name,
    )


def _row_info(row: TrackRow | quick.Record, entry: TrackEntry) -> TrackInfo:
    return TrackInfo(
        name=row.name,
        source="imported",
        path=row.path,
        length=row.length,
        width=row.width,
        direction=row.direction,
        closed=row.closed,
        n_waypoints=row.n_waypoints,
        notes=list(row.notes or []),
        created_at=row.created_at,
        display_name=entry.display_name,
    )


def file_sha256(path: Path) -> str:
    """sha256 of a file's bytes."""
    return hashlib.sha256(path.read_bytes()).hexdigest()


def check_source(source: str | None) -> str | None:
    """``source`` in lower case when it names one (``drx``, ``deepracer``, ``imported``).

    :raises SettingError: another word.
    """
    if source is None:
        return None
    if source.lower() not in SOURCES:
        raise SettingError(
            "{field} {value!r} is unknown; use drx, deepracer or imported.", "source", value=source
        )
    return source.lower()


def matches(info: TrackInfo, search: str) -> bool:
    """Whether ``search`` is part of the track's name or display name (any case; punctuation and
    spaces ignored, so ``reinvent`` finds "re:Invent 2018")."""
    words = name_key(search)[0] or search.lower()
    return any(words in name_key(text)[0] or search.lower() in text.lower()
               for text in (info.name, info.display_name or ""))  # fmt: skip


def list_tracks(search: str | None = None, source: str | None = None) -> list[TrackInfo]:
    """The tracks one can train on: DeepRacer's shipped routes (by display name), drx's own, then the
    imported ones (by name).

    :param search: keep the tracks whose name or display name holds this text (:func:`matches`).
    :param source: keep one source's tracks: ``deepracer``, ``drx`` or ``imported``.
    :raises SettingError: an unknown source.
    """
    wanted = check_source(source)
    infos = shipped_track_infos() if wanted in (None, "deepracer", "drx") else []
    if wanted in (None, "imported"):
        for row in _imported_rows():
            stem = Path(row.source_path).stem if row.source_path else None
            infos.append(_row_info(row, imported_entry(row.name, Path(row.path), stem)))
    if wanted is not None:
        infos = [i for i in infos if i.source == wanted]
    if search:
        infos = [i for i in infos if matches(i, search)]
    return infos


def _imported_rows() -> list[Any]:
    """The imported tracks' rows by name (read at once from a current SQLite registry)."""
    rows = quick.imported_tracks()
    if rows is not None:
        return rows
    from sqlalchemy import select

    from drx.registry import TrackRow, session_scope

    with session_scope() as session:
        return list(session.scalars(select(TrackRow).order_by(TrackRow.name)))


def shipped_track_infos() -> list[TrackInfo]:
    """The shipped tracks' facts, from a cache in the data home (``cache/track-facts.json``) while
    each route file is unchanged (same path, size and modification time); on a miss they are
    measured from the route (:func:`drx.sim.track.route_facts`, ~3 ms a track, NumPy loaded)."""
    cached = _facts_cache()
    infos, fresh = [], {}
    for entry in shipped_tracks():
        key, stamp, facts = _cached_facts(entry, cached)
        if facts is None:  # a miss, or another version's cache
            from drx.sim.track import route_facts  # NumPy and the geometry: on a cache miss only

            facts = route_facts(entry.path)
        path = str(entry.path)
        infos.append(TrackInfo(entry.name, entry.source, path, display_name=entry.display_name, **facts))
        fresh[key] = {"stamp": stamp, "facts": facts}
    if fresh != cached:
        with contextlib.suppress(OSError):  # a read-only data home still lists its tracks, only slower
            write_json_atomic(data_home() / "cache" / FACTS_CACHE, fresh)
    return infos


def _facts_cache() -> dict[str, Any]:
    """The shipped tracks' cached facts (``{}`` when there are none yet or the file is unreadable)."""
    try:
        cached = json.loads((data_home() / "cache" / FACTS_CACHE).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    return cached if isinstance(cached, dict) else {}


def _cached_facts(entry: TrackEntry, cached: dict[str, Any]) -> tuple[str, list[Any], dict[str, Any] | None]:
    """The cache's key and stamp for ``entry``, and its facts when the cache holds them for this very
    file (``None`` otherwise)."""
    st = entry.path.stat()
    stamp = [str(entry.path), st.st_size, st.st_mtime_ns]
    key = f"{entry.source}/{entry.name}"
    hit = cached.get(key)
    facts = hit.get("facts") if isinstance(hit, dict) and hit.get("stamp") == stamp else None
    return key, stamp, facts if isinstance(facts, dict) and set(facts) == FACT_KEYS else None


def show_track(name: str) -> tuple[TrackInfo, Track]:
    """Full facts (with corners) and geometry of track ``name`` (or of a ``.npy`` route file)."""
    from drx.sim.track import Track
    from drx.sim.track_names import display_name

    if name.lower().endswith(".npy"):
        route_path = Path(name).expanduser()
        track, route_notes = Track.from_route(read_route(route_path), route_path.stem)
        info = describe(track, "file", route_path, route_notes, display_name(route_path.stem))
        return info, track
    entry = find_track(name)
    track = load_entry(entry)
    created = None
    notes: list[str] | None = None
    if entry.source == "imported":
        from sqlalchemy import select

        from drx.registry import TrackRow, session_scope

        with session_scope() as session:
            row = session.scalar(select(TrackRow).where(TrackRow.name == entry.name))
            created, notes = (row.created_at, list(row.notes or [])) if row else (None, None)
    info = describe(track, entry.source, entry.path, notes, entry.display_name)
    info.created_at = created
    return info, track


def read_route(path: Path) -> np.ndarray:
    """Load a ``.npy`` route array without executing pickles.

    :raises DrxError: missing, not ``.npy`` or unreadable.
    """
    from drx.sim.route import read_route_file

    if not path.is_file():
        raise not_a_file(path, "Track file", "give a DeepRacer route .npy file")
    if path.suffix.lower() != ".npy":
        raise DrxError(
            f"Track file {path.name} is not a .npy file; give a DeepRacer route (.npy, shape (N, 6))."
        )
    return read_route_file(path)


def _skew_note(track: Track) -> str | None:
    import numpy as np

    rowwise = np.hypot(*(track.inner - track.outer).T)
    true = _widths(track)
    if float(np.median(rowwise)) > SKEW_NOTE_RATIO * float(np.median(true)):
        return (
            "Border rows are not perpendicular to the centre line; widths are measured as DeepRacer does "
            "(between the border points nearest to the centre line)."
        )
    return None


def _check_not_shipped(name: str) -> None:
    """Refuse an import name that a shipped track answers to (the import could never be reached).

    :raises NameTakenError: naming the shipped track and ``--name``.
    """
    try:
        taken = find(name, shipped_tracks())
    except DrxError:  # a display name of several shipped tracks
        what = "the name of several tracks drx ships"
    else:
        if taken is None:
            return
        if taken.source == "drx":
            what = f"one of drx's own tracks ({taken.name})"
        else:
            what = f"DeepRacer's {taken.display_name or taken.name} (route {taken.name}), which drx ships"
    raise NameTakenError(
        "Track {name!r} is {what}; use that track as it is, or import this file under another {field}.",
        "track_name",
        name=name,
        what=what,
    )


def import_track(path: Path, name: str | None = None) -> TrackInfo:
    """Import a DeepRacer route: validate and fix it, copy it to ``$DRX_HOME/tracks``, register it.

    :param path: the ``.npy`` route file.
    :param name: the track's name (default: the file's stem); it may not be one a shipped track
        answers to (its route id or display name).
    :return: the imported track's facts, with the notes on what was fixed.
    :raises DrxError: malformed file, bad, shipped or duplicate name. Nothing is written then.
    """
    import numpy as np

    from drx.sim.track import Track

    if name is None and not ITEM_NAME_RE.fullmatch(path.stem):
        raise SettingError(
            "The file name {stem!r} is not a valid track name; give one with {field} ({rule}).",
            "track_name",
            stem=path.stem,
            rule=NAME_RULE,
        )
    name = check_item_name(name or path.stem, "track")
    route = read_route(path)
    track, notes = Track.from_route(route, name)
    skew = _skew_note(track)
    if skew:
        notes = [*notes, skew]
    if not track.closed:
        notes = [*notes, "The track is open (its ends do not meet); a lap ends at the far end."]
    _check_not_shipped(name)
    folder = data_home() / "tracks"
    folder.mkdir(parents=True, exist_ok=True)
    dest = folder / f"{name}.npy"
    entry = imported_entry(name, dest, path.stem)
    info = describe(track, "imported", dest, notes, entry.display_name)
    from sqlalchemy import select

    from drx.registry import TrackRow, session_scope

    with session_scope() as session:
        if session.scalar(select(TrackRow.id).where(TrackRow.name == name)) is not None:
            raise NameTakenError(
                "Track {name!r} already exists; choose another {field}.", "track_name", name=name
            )
        with atomic_write(dest, "wb") as fh:
            np.save(fh, np.ascontiguousarray(track.to_route(), dtype=np.float64), allow_pickle=False)
        try:
            session.add(
                TrackRow(
                    name=name,
                    path=str(dest),
                    source_path=str(path.resolve()),
                    sha256=file_sha256(dest),
                    length=info.length,
                    width=info.width,
                    direction=info.direction,
                    closed=info.closed,
                    n_waypoints=info.n_waypoints,
                    notes=notes,
                )
            )
            session.flush()
        except BaseException:  # no row, so no route file either
            dest.unlink(missing_ok=True)
            raise
    return info


def remove_track(name: str) -> None:
    """Remove an imported track (its copied route and its row).

    :raises DrxError: the track is shipped, unknown, or used by a model.
    """
    from sqlalchemy import select

    from drx.registry import Model, TrackRow, session_scope

    with session_scope() as session:
        row = session.scalar(select(TrackRow).where(TrackRow.name == name))
        if row is not None:
            users = list(session.scalars(select(Model.name).where(Model.track_name == name).limit(5)))
            if users:
                raise DrxError(
                    f"Track {name!r} is used by model(s) {', '.join(users)}; remove those models first."
                )
            Path(row.path).unlink(missing_ok=True)
            session.delete(row)
            return
    entry = find_track(name)  # raises NotFoundError with near matches
    if entry.source != "imported":
        named = f" ({entry.display_name})" if entry.display_name else ""
        raise DrxError(f"Track {entry.name!r}{named} is shipped with drx and cannot be removed.")


def write_track_png(track: Track, path: Path, width: int = 1200) -> Path:
    """Draw ``track`` from above to a PNG file (``drx track show --png``)."""
    import cv2

    from drx.sim.pictures import track_picture

    rgb = track_picture(track, width=width)
    path.parent.mkdir(parents=True, exist_ok=True)
    if not cv2.imwrite(str(path), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR)):
        raise DrxError(f"Cannot write the picture to {path}; give a writable path ending in .png.")
    return path
