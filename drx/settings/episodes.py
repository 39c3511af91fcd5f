"""Where and which way a model's training episodes start, and on which tracks.

DeepRacer's training options, each under its DeepRacer name (:data:`DEEPRACER_KEYS`):

* the **direction** (``TRACK_DIRECTION_CLOCKWISE``): the console and DeepRacer on AWS name a
  two-way track without its suffix and drive its ``_cw``/``_ccw`` route (deepracer-simapp
  ``bundle/markov/boto/s3/files/yaml_file.py``, ``_update_world_name``); a route driven against
  its own order is the simulator's ``REVERSE_DIR`` (``bundle/markov/track_geom/track_data.py``,
  the waypoints reversed, as :meth:`drx.sim.track.Track.reversed`).
* ``ALTERNATE_DRIVING_DIRECTION`` (default false): after every training episode the direction
  flips (``bundle/markov/agent_ctrl/rollout_agent_ctrl.py``, ``finish_episode``).
* ``CHANGE_START_POSITION`` (default true), ``ROUND_ROBIN_ADVANCE_DIST`` (0.05) and
  ``START_POSITION_OFFSET`` (0.0): the first episode starts ``START_POSITION_OFFSET`` of the lap
  from the start line, and after each training episode the start moves on by
  ``ROUND_ROBIN_ADVANCE_DIST`` (``(start + advance) % 1.0``, ``finish_episode`` again; defaults
  from ``bundle/markov/rollout_worker.py``). Without ``CHANGE_START_POSITION`` every episode
  starts at the offset. The fraction is measured along the direction driven.
* **several tracks**: deepracer-for-cloud's ``DR_TRAIN_MULTI_CONFIG`` gives each rollout worker
  its own world, each keeping its own round robin (``scripts/training/prepare-config.py``). drx
  drives episode ``g`` on track ``g mod n`` of the model's ``n`` tracks, as that track's episode
  ``g // n``, so each track gets its own round robin (and its own alternation) whatever the number
  of rollout workers.

This module is pure: the tracks come resolved (route ids, the direction driven, reversed or not)
from the track catalogue (:func:`drx.services.tracks.find_directed`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

from drx.errors import SettingError

DIRECTIONS = ("cw", "ccw")
DIRECTION_NAMES = {"cw": "clockwise", "ccw": "counter-clockwise"}
# What a user may type for a direction (lower case, spaces and underscores read as dashes).
DIRECTION_WORDS = {
    "cw": "cw",
    "clockwise": "cw",
    "ccw": "ccw",
    "counterclockwise": "ccw",
    "counter-clockwise": "ccw",
}
OPEN = "-"  # the direction of an open track (its ends do not meet): it has none
# ROUND_ROBIN_ADVANCE_DIST's and START_POSITION_OFFSET's defaults (simapp bundle/markov/rollout_worker.py)
DEFAULT_ROUND_ROBIN_ADVANCE = 0.05
DEFAULT_START_POSITION_OFFSET = 0.0
OPTION_KEYS = ("alternate_direction", "change_start_position", "round_robin_advance", "start_position_offset")
DEEPRACER_KEYS = {
    "direction": "TRACK_DIRECTION_CLOCKWISE",
    "alternate_direction": "ALTERNATE_DRIVING_DIRECTION",
    "change_start_position": "CHANGE_START_POSITION",
    "round_robin_advance": "ROUND_ROBIN_ADVANCE_DIST",
    "start_position_offset": "START_POSITION_OFFSET",
}


def parse_direction(value: str | None) -> str | None:
    """``cw`` or ``ccw`` for what a user typed (``clockwise``, ``counter-clockwise``, ``CCW``...);
    ``None`` for ``None`` (each route's own direction).

    :raises SettingError: any other word.
    """
    if value is None:
        return None
    key = str(value).strip().lower().replace("_", "-").replace(" ", "-")
    if key not in DIRECTION_WORDS:
        raise SettingError(
            "{field} {value!r} is unknown; use cw (clockwise) or ccw (counter-clockwise).",
            "direction",
            value=value,
        )
    return DIRECTION_WORDS[key]


def start_fraction(
    round_: int,
    advance: float = DEFAULT_ROUND_ROBIN_ADVANCE,
    offset: float = DEFAULT_START_POSITION_OFFSET,
    change: bool = True,
) -> float:
    """Where a track's episode ``round_`` (its own running number, from 0) starts, as a fraction of
    the lap: DeepRacer's round robin, ``offset`` advanced by ``advance`` after every episode
    (deepracer-simapp ``bundle/markov/agent_ctrl/rollout_agent_ctrl.py``, ``finish_episode``)."""
    if not change:
        return offset % 1.0
    return (offset + round_ * advance) % 1.0


@dataclass(frozen=True)
class TrainingTrack:
    """One track a model trains on, resolved once by the track catalogue.

    :param name: its canonical name (a route id, ``reInvent2019_wide_cw``).
    :param direction: the way its episodes drive it: ``cw``, ``ccw``, ``-`` for an open track,
        ``None`` when unrecorded (a model from before directions: its route's own).
    :param reverse: its episodes drive the route against the order of its waypoints
        (:meth:`drx.sim.track.Track.reversed`, DeepRacer's ``REVERSE_DIR``): a direction that
        route has no ``_cw``/``_ccw`` variant for.
    """

    name: str
    direction: str | None = None
    reverse: bool = False

    def __post_init__(self) -> None:
        if self.direction not in (*DIRECTIONS, OPEN, None):
            raise SettingError(
                "{field} {value!r} is unknown; use cw or ccw.", "direction", value=self.direction
            )
        object.__setattr__(self, "reverse", bool(self.reverse))

    @property
    def is_open(self) -> bool:
        """Whether the track is open (its ends do not meet)."""
        return self.direction == OPEN

    @property
    def label(self) -> str:
        """``reinvent_base (clockwise, reversed)``; the name alone when the direction is unrecorded."""
        if self.direction is None:
            return self.name
        if self.is_open:
            return f"{self.name} (open)"
        way = DIRECTION_NAMES[self.direction]
        return f"{self.name} ({way}, reversed)" if self.reverse else f"{self.name} ({way})"

    def to_dict(self) -> dict[str, Any]:
        """JSON form."""
        return {"name": self.name, "direction": self.direction, "reverse": self.reverse}

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> TrainingTrack:
        """Inverse of :meth:`to_dict`."""
        return cls(str(data["name"]), data.get("direction"), bool(data.get("reverse", False)))


@dataclass(frozen=True)
class EpisodeStart:
    """Where one training episode starts.

    :param track: the index of its track in :attr:`EpisodeSettings.tracks`.
    :param reverse: it drives that track's route reversed.
    :param fraction: [0, 1) of the lap from the start line, along the direction driven.
    :param round: the track's own running episode number (its round robin's position).
    """

    track: int
    reverse: bool
    fraction: float
    round: int


def _fraction(value: Any, field: str, low_open: bool, usage: str) -> float:
    """``value`` as a fraction of the lap: ``0 < value < 1`` (``low_open``) or ``0 <= value < 1``."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = math.nan
    if isinstance(value, bool) or not (0.0 < number < 1.0 or (not low_open and number == 0.0)):
        raise SettingError("{field} {value} is out of range; " + usage, field, value=value)
    return number


@dataclass(frozen=True)
class EpisodeSettings:
    """Where and which way a model's training episodes start, and on which tracks (the module
    docstring has DeepRacer's names and behaviour).

    :param tracks: the tracks, resolved; the first is the model's track (its ``track_name``), which
        the trainer's evaluation and the model's default evaluation drive. Empty for a model made
        before these settings: its ``track_name``, its route's own way.
    :param direction: the direction asked for (``cw``/``ccw``), ``None`` for each route's own; a
        clone given other tracks drives them this way too.
    :param alternate_direction: each track's episodes alternate between its direction and the
        other (``ALTERNATE_DRIVING_DIRECTION``); loops only.
    :param change_start_position: round-robin starts (``CHANGE_START_POSITION``); off: every
        episode starts at ``start_position_offset``.
    :param round_robin_advance: the fraction of the lap the start moves on after each of a
        track's episodes, ``0 < f < 1`` (``ROUND_ROBIN_ADVANCE_DIST``).
    :param start_position_offset: the first episode's start, a fraction of the lap, ``0 <= f < 1``
        (``START_POSITION_OFFSET``).
    :raises SettingError: a value out of range, a track given twice, open tracks with loops, or
        alternating on an open track.
    """

    tracks: tuple[TrainingTrack, ...] = ()
    direction: str | None = None
    alternate_direction: bool = False
    change_start_position: bool = True
    round_robin_advance: float = DEFAULT_ROUND_ROBIN_ADVANCE
    start_position_offset: float = DEFAULT_START_POSITION_OFFSET

    def __post_init__(self) -> None:
        tracks = tuple(t if isinstance(t, TrainingTrack) else TrainingTrack.from_dict(t) for t in self.tracks)
        object.__setattr__(self, "tracks", tracks)
        object.__setattr__(self, "direction", parse_direction(self.direction))
        object.__setattr__(self, "alternate_direction", bool(self.alternate_direction))
        object.__setattr__(self, "change_start_position", bool(self.change_start_position))
        advance = _fraction(
            self.round_robin_advance, "round_robin_advance", True,
            "use a fraction of the lap between 0 and 1, e.g. 0.05 "
            "(5%, DeepRacer's ROUND_ROBIN_ADVANCE_DIST).",
        )  # fmt: skip
        offset = _fraction(
            self.start_position_offset, "start_position_offset", False,
            "use a fraction of the lap from 0 up to 1 (not 1 itself), e.g. 0.25 "
            "(DeepRacer's START_POSITION_OFFSET).",
        )  # fmt: skip
        object.__setattr__(self, "round_robin_advance", advance)
        object.__setattr__(self, "start_position_offset", offset)
        self._check_tracks()

    def _check_tracks(self) -> None:
        seen: set[str] = set()
        for track in self.tracks:
            if track.name in seen:
                raise SettingError(
                    "{field} {name!r} is given twice; give each track once.", "track", name=track.name
                )
            seen.add(track.name)
        open_ = [t.name for t in self.tracks if t.is_open]
        loops = [t.name for t in self.tracks if t.direction in DIRECTIONS]
        if open_ and loops:
            raise SettingError(
                "Track {open!r} is open and {loop!r} is a loop; one model trains on loops or on open "
                "tracks, so give {field} only one kind.",
                "track",
                open=open_[0],
                loop=loops[0],
            )
        if open_ and self.alternate_direction:
            raise SettingError(
                "{field} needs a loop, and track {name!r} is open (its ends do not meet); train open "
                "tracks without {field}.",
                "alternate_direction",
                name=open_[0],
            )

    # ----- reading ---------------------------------------------------------------------------------
    @property
    def track_names(self) -> list[str]:
        """The tracks' route ids, the model's own first."""
        return [t.name for t in self.tracks]

    @property
    def first(self) -> TrainingTrack | None:
        """The model's track (evaluated by the trainer and by default), ``None`` when unrecorded."""
        return self.tracks[0] if self.tracks else None

    def start(self, episode: int) -> EpisodeStart:
        """Where training episode ``episode`` (the model's running number, from 0) starts.

        Episode ``g`` drives track ``g mod n`` as that track's episode ``k = g // n``: from
        ``start_position_offset + k x round_robin_advance`` of the lap (or the offset alone without
        ``change_start_position``), reversed when the track is and, with ``alternate_direction``,
        the other way round on every odd ``k`` (DeepRacer flips after each episode).
        """
        n = max(1, len(self.tracks))
        index, round_ = int(episode) % n, int(episode) // n
        reverse = bool(self.tracks[index].reverse) if self.tracks else False
        if self.alternate_direction and round_ % 2 == 1:
            reverse = not reverse
        fraction = start_fraction(
            round_, self.round_robin_advance, self.start_position_offset, self.change_start_position
        )
        return EpisodeStart(index, reverse, fraction, round_)

    def describe_starts(self) -> str:
        """The starts for people: ``round robin: +5% of the lap an episode from 0%``."""
        offset = f"{100 * self.start_position_offset:g}%"
        if not self.change_start_position:
            text = f"every episode at {offset} of the lap"
        else:
            text = f"round robin: +{100 * self.round_robin_advance:g}% of the lap an episode from {offset}"
        return text + (", alternating direction every episode" if self.alternate_direction else "")

    # ----- changing --------------------------------------------------------------------------------
    def overridden(self, given: dict[str, Any] | None, **changes: Any) -> EpisodeSettings:
        """These settings with the options a user gave (``None`` = not given; keys :data:`OPTION_KEYS`)
        and ``changes`` (new ``tracks``, ``direction``), checked together (a clone given an open
        track and ``alternate_direction=False`` drops its parent's alternation before the check).

        :raises SettingError: a value out of range, settings that do not fit the tracks, or a
            round-robin advance given while the starts do not move (it would do nothing).
        """
        given = {k: v for k, v in (given or {}).items() if k in OPTION_KEYS and v is not None}
        result = replace(self, **changes, **given)
        if "round_robin_advance" in given and not result.change_start_position:
            raise SettingError(
                "{field} {value} does nothing while {change_start_position} is off (every episode "
                "starts at the same place); turn {change_start_position} on or leave out {field}.",
                "round_robin_advance",
                "change_start_position",
                value=given["round_robin_advance"],
            )
        return result

    def to_dict(self) -> dict[str, Any]:
        """JSON form (a model's ``episode_options`` column)."""
        return {
            "tracks": [t.to_dict() for t in self.tracks],
            "direction": self.direction,
            "alternate_direction": self.alternate_direction,
            "change_start_position": self.change_start_position,
            "round_robin_advance": self.round_robin_advance,
            "start_position_offset": self.start_position_offset,
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any] | None, track: str | None = None) -> EpisodeSettings:
        """Settings from their JSON; ``None`` or missing keys take DeepRacer's defaults.

        :param track: the model's ``track_name``, the one track of settings that list none (models
            from before these settings), driven its route's own way.
        """
        data = dict(data or {})
        tracks = [TrainingTrack.from_dict(t) for t in data.pop("tracks", None) or ()]
        if not tracks and track is not None:
            tracks = [TrainingTrack(track)]
        known = {k: v for k, v in data.items() if k in cls.__dataclass_fields__ and v is not None}
        return cls(tracks=tuple(tracks), **known)
