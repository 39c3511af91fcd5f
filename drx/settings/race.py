"""Race types and their settings: time trial, object avoidance, head-to-bot.

A :class:`RaceConfig` is what a model stores (its ``race`` JSON) and what the
environment takes (``gymnasium.make("drx/DeepRacer-v0", race=...)``). Ranges are
DeepRacer's (``../shared/DEEPRACER.md`` section 5):

* object avoidance: 1-6 static boxes between 7% and 90% of the lap from the
  start line, at least 13% of the lap apart, each in the inside or outside lane;
  fixed (evenly spread, alternating lanes, or the user's own places) or
  randomised per training episode;
* head-to-bot: 1-4 bot cars at 0.2-6 m/s driving the lanes, optionally changing
  lanes every 3-5 s;
* head-to-model: 1-3 of the user's trained models (``opponents``, their registry ids) drive the
  other cars of every training episode (:mod:`drx.evaluate.head_to_model`); deepracer-for-cloud's
  ``DR_RACE_TYPE=HEAD_TO_MODEL`` (``docs/head-to-head.md``), there for evaluations only.

Every check raises :class:`~drx.errors.DrxError` with one sentence, before
anything is stored or simulated.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

from drx.errors import DrxError, SettingError

RACE_TYPES = ("time-trial", "object-avoidance", "head-to-bot", "head-to-model")
OBJECTS_RANGE = (1, 6)
OBJECT_PLACE_RANGE = (0.07, 0.90)  # fraction of the lap from the start line
OBJECT_MIN_GAP = 0.13  # fraction of the lap between two boxes
BOTS_RANGE = (1, 4)
OPPONENTS_RANGE = (1, 3)  # models driving the other cars of a head-to-model training
BOT_SPEED_RANGE = (0.2, 6.0)  # [m/s]
DEFAULT_OBJECTS = 3
DEFAULT_BOTS = 3
DEFAULT_BOT_SPEED = 0.2  # [m/s] DeepRacer's default BOT_CAR_SPEED
LANES = ("inside", "outside")
# DeepRacer's names (model settings, deepracer-for-cloud's run.env) -> drx's.
_ALIASES = {
    "time_trial": "time-trial",
    "timetrial": "time-trial",
    "object_avoidance": "object-avoidance",
    "objectavoidance": "object-avoidance",
    "head_to_bot": "head-to-bot",
    "headtobot": "head-to-bot",
    "head_to_model": "head-to-model",
    "headtomodel": "head-to-model",
}
_LANE_ALIASES = {
    "inside": "inside",
    "inner": "inside",
    "1": "inside",
    "outside": "outside",
    "outer": "outside",
    "out": "outside",
    "in": "inside",
    "-1": "outside",
}


@dataclass(frozen=True)
class RaceConfig:
    """A race type and its settings (validated on construction).

    :param race_type: ``time-trial``, ``object-avoidance`` or ``head-to-bot``.
    :param objects: number of boxes (object avoidance), 1-6; ``None``: as many as
        ``object_positions``, else 3. Other race types have 0.
    :param object_positions: the user's own fixed places: ``(fraction of the lap, lane)`` pairs,
        lane ``inside`` or ``outside``; empty for drx's (DeepRacer's) evenly spread placement.
    :param randomize_objects: new random places (and lanes) every training episode.
    :param bots: number of bot cars (head-to-bot), 1-4; ``None``: 3. Other race types have 0.
    :param bot_speed: the bots' speed [m/s], 0.2-6; ``None``: DeepRacer's 0.2 (head-to-bot only).
    :param bot_lane_change: bots change lanes every 3-5 s.
    :param randomize_bots: new random bot places and lanes every training episode.
    :param opponents: head-to-model: the registry ids of the 1-3 models driving the other cars
        (checked against the registry by :mod:`drx.services.opponents`). Other race types have none.
    """

    race_type: str = "time-trial"
    objects: int | None = None
    object_positions: tuple[tuple[float, str], ...] = field(default=())
    randomize_objects: bool = False
    bots: int | None = None
    bot_speed: float | None = None
    bot_lane_change: bool = False
    randomize_bots: bool = False
    opponents: tuple[int, ...] = field(default=())

    def __post_init__(self) -> None:
        kind = normalise_race_type(self.race_type)
        object.__setattr__(self, "race_type", kind)
        positions = tuple(sorted(_position(p) for p in self.object_positions))
        object.__setattr__(self, "object_positions", positions)
        if kind != "object-avoidance" and (self.objects or positions or self.randomize_objects):
            raise SettingError(
                "Objects ({objects}, {object_positions}, {randomize_objects}) need "
                "{race_type} object-avoidance, not {kind}.",
                "objects",
                "object_positions",
                "randomize_objects",
                "race_type",
                kind=kind,
            )
        bot_settings = self.bots or self.bot_lane_change or self.randomize_bots or self.bot_speed is not None
        if kind != "head-to-bot" and bot_settings:
            raise SettingError(
                "Bots ({bots}, {bot_speed}, {bot_lane_change}) need {race_type} head-to-bot, not {kind}.",
                "bots",
                "bot_speed",
                "bot_lane_change",
                "race_type",
                kind=kind,
            )
        self._check_opponents(kind)
        if kind != "object-avoidance":
            object.__setattr__(self, "objects", 0)
        if kind != "head-to-bot":
            object.__setattr__(self, "bots", 0)
        if kind == "object-avoidance":
            self._check_objects(positions)
        if kind == "head-to-bot":
            n = DEFAULT_BOTS if self.bots is None else int(self.bots)
            if not BOTS_RANGE[0] <= n <= BOTS_RANGE[1]:
                raise SettingError(
                    "{field} {value} is out of range; use {lo}-{hi} bot cars.",
                    "bots",
                    value=self.bots,
                    lo=BOTS_RANGE[0],
                    hi=BOTS_RANGE[1],
                )
            object.__setattr__(self, "bots", n)
            speed = DEFAULT_BOT_SPEED if self.bot_speed is None else float(self.bot_speed)
            if not BOT_SPEED_RANGE[0] <= speed <= BOT_SPEED_RANGE[1]:
                raise SettingError(
                    "{field} {value:g} m/s is out of range; use {lo:g}-{hi:g} m/s.",
                    "bot_speed",
                    value=speed,
                    lo=BOT_SPEED_RANGE[0],
                    hi=BOT_SPEED_RANGE[1],
                )
            object.__setattr__(self, "bot_speed", speed)

    def _check_opponents(self, kind: str) -> None:
        ids = tuple(self.opponents)
        if kind != "head-to-model":
            if ids:
                raise SettingError("{field} needs {race_type} head-to-model, not {kind}.", "opponents",
                                   "race_type", kind=kind)  # fmt: skip
            return
        lo, hi = OPPONENTS_RANGE
        if not lo <= len(ids) <= hi:
            raise SettingError("{race_type} head-to-model takes {lo} to {hi} {field}, not {n}.", "opponents",
                               "race_type", lo=lo, hi=hi, n=len(ids))  # fmt: skip
        if any(isinstance(i, bool) or not isinstance(i, int) for i in ids) or len(set(ids)) != len(ids):
            raise DrxError(f"Opponents {list(ids)} must be distinct model ids.")
        object.__setattr__(self, "opponents", ids)

    def _check_objects(self, positions: tuple[tuple[float, str], ...]) -> None:
        n = (len(positions) or DEFAULT_OBJECTS) if self.objects is None else int(self.objects)
        if not OBJECTS_RANGE[0] <= n <= OBJECTS_RANGE[1]:
            raise SettingError(
                "{field} {value} is out of range; use {lo}-{hi} boxes.",
                "objects",
                value=self.objects,
                lo=OBJECTS_RANGE[0],
                hi=OBJECTS_RANGE[1],
            )
        if positions:
            if self.randomize_objects:
                raise SettingError(
                    "{field} places boxes at fixed places; drop it or {randomize_objects}.",
                    "object_positions",
                    "randomize_objects",
                )
            if len(positions) != n:
                raise SettingError(
                    "{field} {value} does not match the {places} places given with {object_positions}.",
                    "objects",
                    "object_positions",
                    value=n,
                    places=len(positions),
                )
            lo, hi = OBJECT_PLACE_RANGE
            for frac, _ in positions:
                if not lo - 1e-9 <= frac <= hi + 1e-9:
                    raise DrxError(
                        f"A box at {100 * frac:g}% of the lap is out of range; place boxes between "
                        f"{100 * lo:g}% and {100 * hi:g}%."
                    )
            for (a, _), (b, _) in zip(positions, positions[1:], strict=False):
                if b - a < OBJECT_MIN_GAP - 1e-9:
                    raise DrxError(
                        f"Boxes at {100 * a:g}% and {100 * b:g}% of the lap overlap; keep them at "
                        f"least {100 * OBJECT_MIN_GAP:g}% of the lap apart."
                    )
        object.__setattr__(self, "objects", n)

    # ----- resolved values (``None`` in a field means DeepRacer's default until __post_init__) -----
    @property
    def box_count(self) -> int:
        """How many boxes the race has (0 outside object avoidance)."""
        assert self.objects is not None  # __post_init__ resolves it
        return self.objects

    @property
    def bot_count(self) -> int:
        """How many bot cars the race has (0 outside head-to-bot)."""
        assert self.bots is not None  # __post_init__ resolves it
        return self.bots

    @property
    def bot_speed_mps(self) -> float:
        """The bots' speed [m/s] (head-to-bot; DeepRacer's default elsewhere, where no bot drives)."""
        return DEFAULT_BOT_SPEED if self.bot_speed is None else self.bot_speed

    # ----- forms --------------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """JSON form (a model's ``race`` column)."""
        return {
            "race_type": self.race_type,
            "objects": self.objects,
            "object_positions": [[f, lane] for f, lane in self.object_positions],
            "randomize_objects": self.randomize_objects,
            "bots": self.bots,
            "bot_speed": self.bot_speed,
            "bot_lane_change": self.bot_lane_change,
            "randomize_bots": self.randomize_bots,
            **({"opponents": list(self.opponents)} if self.opponents else {}),
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any] | None) -> RaceConfig:
        """Read :meth:`to_dict`'s form (missing keys take defaults; ``None`` is a time trial)."""
        d = dict(d or {})
        known = {
            "race_type",
            "objects",
            "object_positions",
            "randomize_objects",
            "bots",
            "bot_speed",
            "bot_lane_change",
            "randomize_bots",
            "opponents",
        }
        unknown = sorted(set(d) - known)
        if unknown:
            raise DrxError(
                f"Unknown race setting(s) {', '.join(unknown)}; known: {', '.join(sorted(known))}."
            )
        d["object_positions"] = tuple(tuple(p) for p in d.get("object_positions") or ())
        d["opponents"] = tuple(d.get("opponents") or ())
        return cls(**{k: v for k, v in d.items() if v is not None})

    def with_changes(self, **changes: Any) -> RaceConfig:
        """A validated copy with some settings changed."""
        return replace(self, **changes)

    @property
    def has_objects(self) -> bool:
        """Whether the track carries boxes or bots (a head-to-model training's cars are added by its
        training env, :mod:`drx.evaluate.head_to_model`; its evaluations are time trials)."""
        return self.race_type in ("object-avoidance", "head-to-bot")

    def summary(self) -> str:
        """One line for people: ``object-avoidance, 3 boxes (random)``."""
        if self.race_type == "object-avoidance":
            how = "random" if self.randomize_objects else ("placed" if self.object_positions else "fixed")
            return f"object-avoidance, {self.objects} boxes ({how})"
        if self.race_type == "head-to-bot":
            lanes = ", lane changes" if self.bot_lane_change else ""
            places = ", random places" if self.randomize_bots else ""
            return f"head-to-bot, {self.bots} bots at {self.bot_speed:g} m/s{lanes}{places}"
        if self.race_type == "head-to-model":
            n = len(self.opponents)
            return f"head-to-model, {n} opponent{'' if n == 1 else 's'}"
        return "time-trial"


def normalise_race_type(value: str) -> str:
    """``time-trial``, ``object-avoidance``, ``head-to-bot`` or ``head-to-model`` from drx's or
    DeepRacer's spelling."""
    text = str(value).strip().lower()
    text = _ALIASES.get(text.replace("-", "_"), text)
    if text not in RACE_TYPES:
        raise SettingError(
            "{field} {value} is unknown; use one of {allowed}.",
            "race_type",
            value=value,
            allowed=", ".join(RACE_TYPES),
        )
    return text


def parse_object_at(text: str) -> tuple[float, str]:
    """A box place from the CLI: ``"25:inside"`` or ``"0.25,1"`` -> ``(0.25, "inside")``.

    The place is a percent of the lap (or a fraction up to 1); the lane ``inside`` / ``outside``
    or DeepRacer's lane numbers ``1`` / ``-1``.
    """
    sep = ":" if ":" in text else ","
    parts = [p.strip() for p in str(text).split(sep)]
    if len(parts) != 2:
        raise SettingError(
            "{field} {value!r} must be PLACE:LANE, e.g. 25:inside (percent of the lap, lane).",
            "object_positions",
            value=text,
        )
    try:
        frac = float(parts[0].rstrip("%"))
    except ValueError:
        raise SettingError(
            "{field} {value!r}: {place!r} is not a number (percent of the lap).",
            "object_positions",
            value=text,
            place=parts[0],
        ) from None
    if frac > 1.0 or parts[0].endswith("%"):
        frac /= 100.0
    return _position((frac, parts[1]))


def _position(p: Any) -> tuple[float, str]:
    try:
        frac, lane = p
        frac = float(frac)
    except (TypeError, ValueError):
        raise DrxError(f"A box place {p!r} must be (fraction of the lap, lane).") from None
    name = _LANE_ALIASES.get(str(lane).strip().lower())
    if name is None:
        raise DrxError(f"Lane {lane!r} is unknown; use inside or outside.")
    return round(frac, 6), name


def sensor_warnings(race: RaceConfig, sensor: str, lidar: bool) -> list[str]:
    """Sentences about sensors that serve a race type poorly (allowed, but worth a warning).

    Every drx car has a camera, so every race type can be driven; a car without a lidar
    cannot see bots beside or behind it, and one camera judges a box's distance poorly.
    """
    notes = []
    if race.race_type == "head-to-bot" and not lidar:
        notes.append(
            "This car has no lidar: it cannot see bots beside or behind it (garage car stereo-lidar has one)."
        )
    if race.race_type == "object-avoidance" and sensor != "stereo" and not lidar:
        notes.append(
            "This car has one camera and no lidar: it judges the distance to a box poorly "
            "(a stereo camera or a lidar helps; see garage car stereo-lidar)."
        )
    return notes


TIME_TRIAL = RaceConfig()

__all__ = [
    "BOTS_RANGE",
    "BOT_SPEED_RANGE",
    "LANES",
    "OBJECTS_RANGE",
    "OBJECT_MIN_GAP",
    "OBJECT_PLACE_RANGE",
    "OPPONENTS_RANGE",
    "RACE_TYPES",
    "RaceConfig",
    "TIME_TRIAL",
    "normalise_race_type",
    "parse_object_at",
    "sensor_warnings",
]
