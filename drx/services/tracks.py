"""Tracks: the project's built-in routes and the ones users import.

Built-in tracks are the project's ``tracks/*.npy``. ``drx track import``
reads any DeepRacer route, fixes its quirks (via
:meth:`drx.sim.track.Track.from_route`), writes the fixed route to
``$DRX_HOME/tracks/<name>.npy`` (where :func:`drx.sim.track.load_track` finds
it) and registers it in the ``tracks`` table.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
from dataclasses import asdict, dataclass, field
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

from sqlalchemy import select

from drx.atomic import atomic_write, write_json_atomic
from drx.config import data_home, project_root
from drx.errors import DrxError, NameTakenError, NotFoundError, SettingError, not_a_file
from drx.registry import Model, TrackRow, session_scope
from drx.services.names import ITEM_NAME_RE, NAME_RULE, check_item_name

if TYPE_CHECKING:  # NumPy and the track geometry load in the functions that use them: not for a listing
    import numpy as np

    from drx.sim.track import Track

DEFAULT_TRACK = "oval"
SKEW_NOTE_RATIO = 1.05  # row-wise border distance this much above the true width => rows are skewed


@dataclass
class TrackInfo:
    """A track's facts, as ``drx track list/show`` print them."""

    name: str
    source: str  # "built-in" or "imported"
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

    @property
    def turns(self) -> int:
        """Number of corners (only known once the geometry was loaded)."""
        return len(self.corners)

    def to_dict(self) -> dict[str, Any]:
        """JSON form."""
        return {
            "name": self.name,
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


def builtin_tracks() -> dict[str, Path]:
    """The project's built-in tracks, name -> route file."""
    folder = project_root() / "tracks"
    if not folder.is_dir():
        return {}
    return {p.stem: p for p in sorted(folder.glob("*.npy"), key=lambda p: p.stem)}


def _widths(track: Track, samples: int = 400) -> np.ndarray:
    import numpy as np

    s = np.linspace(0.0, track.length, samples, endpoint=False)
    return np.array([track.width_at(float(v)) for v in s])


def describe(track: Track, source: str, path: Path | str, notes: list[str] | None = None) -> TrackInfo:
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
    )


def _row_info(row: TrackRow) -> TrackInfo:
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
    )


def known_track_names() -> list[str]:
    """Every track name: built-in and imported."""
    with session_scope() as session:
        imported = list(session.scalars(select(TrackRow.name)))
    return sorted({*builtin_tracks(), *imported})


def resolve_track_path(name: str) -> tuple[Path, str]:
    """The route file of track ``name`` and its source (``imported`` or ``built-in``).

    :raises NotFoundError: no such track; the message lists the known names.
    """
    with session_scope() as session:
        row = session.scalar(select(TrackRow).where(TrackRow.name == name))
        if row is not None:
            return Path(row.path), "imported"
    builtin = builtin_tracks().get(name)
    if builtin is not None:
        return builtin, "built-in"
    raise NotFoundError(
        f"No track named {name!r}; known tracks: {', '.join(known_track_names()) or 'none'} "
        "(import one with `drx track import FILE.npy`)."
    )


def load_track_by_name(name: str) -> Track:
    """The geometry of a built-in or imported track (or of a ``.npy`` path)."""
    from drx.sim.track import load_track

    if name.endswith(".npy"):
        return load_track(name)
    path, _ = resolve_track_path(name)
    return load_track(path)


def file_sha256(path: Path) -> str:
    """sha256 of a file's bytes."""
    return hashlib.sha256(path.read_bytes()).hexdigest()


def list_tracks() -> list[TrackInfo]:
    """Built-in tracks (facts computed from their geometry), then imported ones, by name."""
    infos = builtin_track_infos()
    with session_scope() as session:
        infos += [_row_info(r) for r in session.scalars(select(TrackRow).order_by(TrackRow.name))]
    return infos


def builtin_track_infos() -> list[TrackInfo]:
    """The built-in tracks' facts, from a cache in the data home (``cache/builtin-tracks.json``)
    while each route file is unchanged (same size and modification time): loading a track costs
    about 0.15 s of geometry, which ``drx track list`` paid for every track on every run."""
    cache_path = data_home() / "cache" / "builtin-tracks.json"
    try:
        cached = json.loads(cache_path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        cached = {}
    infos, fresh = [], {}
    for name, path in builtin_tracks().items():
        st = path.stat()
        stamp = [str(path), st.st_size, st.st_mtime_ns]
        entry = cached.get(name) if isinstance(cached, dict) else None
        info = None
        if isinstance(entry, dict) and entry.get("stamp") == stamp:
            try:
                info = TrackInfo(**entry["info"])
            except (KeyError, TypeError):
                info = None
        if info is None:
            from drx.sim.track import load_track  # NumPy and the geometry: on a cache miss only

            info = describe(load_track(path), "built-in", path)
        infos.append(info)
        fresh[name] = {"stamp": stamp, "info": asdict(info)}
    if fresh != cached:
        with contextlib.suppress(OSError):  # a read-only data home still lists its tracks, only slower
            write_json_atomic(cache_path, fresh)
    return infos


def show_track(name: str) -> tuple[TrackInfo, Track]:
    """Full facts (with corners) and geometry of track ``name`` (or of a ``.npy`` route file)."""
    from drx.sim.track import Track, load_track

    notes: list[str] | None
    if name.lower().endswith(".npy"):
        route_path = Path(name).expanduser()
        track, route_notes = Track.from_route(read_route(route_path), route_path.stem)
        return describe(track, "file", route_path, route_notes), track
    path, source = resolve_track_path(name)
    track = load_track(path)
    created = None
    notes = None
    if source == "imported":
        with session_scope() as session:
            row = session.scalar(select(TrackRow).where(TrackRow.name == name))
            created, notes = (row.created_at, list(row.notes or [])) if row else (None, None)
    info = describe(track, source, path, notes)
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
    true = _widths(track, 200)
    if float(np.median(rowwise)) > SKEW_NOTE_RATIO * float(np.median(true)):
        return (
            "Border rows are not perpendicular to the centre line; widths are measured as DeepRacer does "
            "(between the border points nearest to the centre line)."
        )
    return None


def import_track(path: Path, name: str | None = None) -> TrackInfo:
    """Import a DeepRacer route: validate and fix it, copy it to ``$DRX_HOME/tracks``, register it.

    :param path: the ``.npy`` route file.
    :param name: the track's name (default: the file's stem).
    :return: the imported track's facts, with the notes on what was fixed.
    :raises DrxError: malformed file, bad or duplicate name. Nothing is written then.
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
    if name in builtin_tracks():
        raise NameTakenError(
            "Track {name!r} is a built-in track; import it under another {field}.", "track_name", name=name
        )
    folder = data_home() / "tracks"
    folder.mkdir(parents=True, exist_ok=True)
    dest = folder / f"{name}.npy"
    info = describe(track, "imported", dest, notes)
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

    :raises DrxError: the track is built in, unknown, or used by a model.
    """
    if name in builtin_tracks():
        raise DrxError(f"Track {name!r} is built in and cannot be removed.")
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
    resolve_track_path(name)  # raises NotFoundError with the known names


def write_track_png(track: Track, path: Path, width: int = 1200) -> Path:
    """Draw ``track`` from above to a PNG file (``drx track show --png``)."""
    import cv2

    from drx.sim.pictures import track_picture

    rgb = track_picture(track, width=width)
    path.parent.mkdir(parents=True, exist_ok=True)
    if not cv2.imwrite(str(path), cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR)):
        raise DrxError(f"Cannot write the picture to {path}; give a writable path ending in .png.")
    return path
