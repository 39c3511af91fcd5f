"""DeepRacer's track names: a route id (``reInvent2019_wide_cw``) -> the name the console shows.

Names are facts taken from public sources, cited here; none is made up. A route none of them
names gets no display name (``None``: "no public display name").

* :data:`CONSOLE_NAMES`: the track list of the self-hosted DeepRacer console, "DeepRacer on AWS"
  (aws-solutions/deepracer-on-aws, ``source/libs/config/src/data/tracks.json`` at commit
  61af778f, Apache-2.0): each track's ``trackId`` (its route id) and ``name``.
  :data:`TWO_WAY` are the tracks whose ``enabledDirections`` hold both directions: the console
  races those on the route ``<trackId>_cw`` or ``<trackId>_ccw``
  (``source/libs/lambda/src/api/utils/RewardFunctionValidator.ts``: ``CLOCKWISE_TRACK_SUFFIX``).
  drx names such a route "<name> (clockwise)" or "<name> (counter-clockwise)", as
  deepracer-log-guru's track classes do (aws-deepracer-community/deepracer-log-guru,
  ``src/tracks/*.py``, ``_ui_name`` beside ``_world_name``: "A to Z Speedway (Clockwise)" for
  ``reInvent2019_wide_cw``), and deepracer-utils ("A to Z Speedway CW").
* :data:`OTHER_NAMES`: routes the console list does not hold (evaluation tracks, variants of
  the re:Invent 2018 track), from deepracer-utils' track table
  (aws-deepracer-community/deepracer-utils, ``deepracer/tracks/track_utils.py``, ``track_meta``,
  at commit 262e3fe3, MIT-0). Its names of the console's tracks agree with the console list.

Listing names needs no NumPy and no route file: ``drx track list`` reads this module.
"""

from __future__ import annotations

import re

# trackId -> name, from DeepRacer on AWS's tracks.json (sorted by name, as the console lists them).
CONSOLE_NAMES: dict[str, str] = {
    "2022_reinvent_champ": "2022 re:Invent Championship",
    "reInvent2019_wide": "A to Z Speedway",
    "2022_april_open": "Ace Speedway",
    "2022_april_pro": "Ace Super Speedway",
    "Austin": "American Hills Speedway",
    "Singapore": "Asia Pacific Bay Loop",
    "Singapore_building": "Asia Pacific Bay Loop - Buildings",
    "Vegas_track": "AWS Summit Raceway",
    "AmericasGeneratedInclStart": "Baadal Track",
    "dubai_pro": "Baja Highway",
    "dubai_open": "Baja Turnpike",
    "Bowtie_track": "Bowtie Track",
    "2022_june_open": "BreadCentric Loop",
    "2022_june_pro": "BreadCentric Speedway",
    "Spain_track": "Circuit de Barcelona-Catalunya",
    "jyllandsringen_pro": "Cosmic Circuit",
    "jyllandsringen_open": "Cosmic Loop",
    "Mexico_track": "Cumulo Carrera Training",
    "Belille": "Cumulo Turnpike",
    "2022_july_open": "DBro Raceway",
    "2022_july_pro": "DBro Super Raceway",
    "New_York_Track": "Empire City Training",
    "Monaco": "European Seaside Circuit",
    "Monaco_building": "European Seaside Circuit - Buildings",
    "red_star_open": "Expedition Loop",
    "red_star_pro": "Expedition Super Loop",
    "2024_reinvent_champ": "Forever Raceway",
    "FS_June2020": "Fumiaki Loop",
    "arctic_open": "Hot Rod Speedway",
    "arctic_pro": "Hot Rod Super Speedway",
    "2022_october_open": "Jennens Family Speedway",
    "2022_october_pro": "Jennens Super Speedway",
    "2022_august_pro": "Jochem Highway",
    "2022_august_open": "Jochem Turnpike",
    "hamption_open": "Kuei Raceway",
    "hamption_pro": "Kuei Super Raceway",
    "Tokyo_Training_track": "Kumo Torakku Training",
    "thunder_hill_pro": "Lars Circuit",
    "thunder_hill_open": "Lars Loop",
    "Virtual_May19_Train_track": "London Loop Training",
    "Oval_track": "Oval Track",
    "morgan_open": "Playa Raceway",
    "morgan_pro": "Playa Super Raceway",
    "penbay_open": "Po-Chun Speedway",
    "penbay_pro": "Po-Chun Super Speedway",
    "reinvent_base": "re:Invent 2018",
    "2022_summit_speedway": "RL Speedway",
    "July_2020": "Roger Raceway",
    "2022_september_open": "Roger Ring",
    "2022_september_pro": "Roger Super Raceway",
    "2022_march_open": "Rogue Circuit",
    "2022_march_pro": "Rogue Raceway",
    "2022_may_open": "Ross Raceway",
    "2022_may_pro": "Ross Super Speedway",
    "China_track": "Shanghai Sudu Training",
    "reInvent2019_track": "Smile Speedway",
    "LGSWide": "SOLA Speedway",
    "Aragon": "Stratus Loop",
    "Canada_Training": "Toronto Turnpike Training",
    "caecer_loop": "Vivalas Loop",
    "caecer_gp": "Vivalas Speedway",
    "Albert": "Yun Speedway",
}

# The console's tracks raced in both directions (tracks.json: enabledDirections holds both).
TWO_WAY: frozenset[str] = frozenset({
    "2022_april_open", "2022_april_pro", "2022_august_open", "2022_august_pro", "2022_july_pro",
    "2022_june_open", "2022_june_pro", "2022_march_open", "2022_march_pro", "2022_may_open",
    "2022_may_pro", "2022_october_open", "2022_october_pro", "2022_reinvent_champ",
    "2022_september_open", "2022_september_pro", "2022_summit_speedway", "2024_reinvent_champ",
    "arctic_open", "arctic_pro", "dubai_open", "jyllandsringen_open", "jyllandsringen_pro",
    "penbay_open", "penbay_pro", "red_star_pro", "reInvent2019_track", "reInvent2019_wide",
    "thunder_hill_pro",
})  # fmt: skip

# Routes outside the console's list, named by deepracer-utils' track_meta.
OTHER_NAMES: dict[str, str] = {
    "2022_summit_speedway_mini": "RL Speedway Mini",
    "Singapore_f1": "Asia Pacific Bay Loop F1",
    "Spain_track_f1": "Circuit de Barcelona-Catalunya F1",
    "reinvent_base_jeremiah": "re:Invent 2018 (Jeremiah)",
    "reinvent_carpet": "re:Invent 2018 (Carpet)",
    "reinvent_concrete": "re:Invent 2018 (Concrete)",
    "reinvent_wood": "re:Invent 2018 (Wood)",
    "Canada_Eval": "Toronto Turnpike Eval",
    "Mexico_track_eval": "Cumulo Carrera Eval",
    "China_eval_track": "Shanghai Sudu Eval",
    "New_York_Eval_Track": "Empire City Eval",
    "reInvent2019_wide_mirrored": "A to Z Speedway Mirrored",
    "H_track": "H track",
    "Straight_track": "Straight track",
    "AWS_track": "AWS Track",
}

# A direction variant's route id suffix -> the words drx puts after its track's name.
DIRECTIONS: dict[str, str] = {"_cw": "clockwise", "_ccw": "counter-clockwise"}
NO_PUBLIC_NAME = "no public display name"


def split_direction(route_id: str) -> tuple[str, str | None]:
    """A route id's track and direction: ``("reInvent2019_wide", "cw")`` for ``reInvent2019_wide_cw``,
    ``(route_id, None)`` for a route that is no direction variant of a console track."""
    for suffix in DIRECTIONS:
        base = route_id.removesuffix(suffix)
        if base != route_id and base in CONSOLE_NAMES:
            return base, suffix[1:]
    return route_id, None


def display_name(route_id: str) -> str | None:
    """The console's name of route ``route_id`` (``"A to Z Speedway (clockwise)"``), or ``None``
    when no public source names it."""
    if route_id in CONSOLE_NAMES:
        return CONSOLE_NAMES[route_id]
    if route_id in OTHER_NAMES:
        return OTHER_NAMES[route_id]
    base, direction = split_direction(route_id)
    if direction is None:
        return None
    return f"{CONSOLE_NAMES[base]} ({DIRECTIONS['_' + direction]})"


def known_route_ids() -> list[str]:
    """Every route id this module names, shipped with drx or not (for "import it first" hints)."""
    variants = [f"{base}{suffix}" for base in sorted(TWO_WAY) for suffix in DIRECTIONS]
    return sorted({*CONSOLE_NAMES, *OTHER_NAMES, *variants}, key=str.lower)


# Words that say a direction in the names people type: "(Clockwise)", "CCW", "counter clockwise".
_DIRECTION_WORDS = (
    (re.compile(r"\b(counter[\s-]*clockwise|counterclockwise|anti[\s-]*clockwise|ccw)\b"), "ccw"),
    (re.compile(r"\b(clockwise|cw)\b"), "cw"),
    (re.compile(r"\boriginal\b"), ""),
)


def name_key(text: str) -> tuple[str, str | None]:
    """A typed name as ``(words, direction)`` for matching: lower case, punctuation dropped,
    the direction words taken out (``"A to Z Speedway (Clockwise)"`` -> ``("atozspeedway", "cw")``).

    :param text: a display name or a route id, as a user types it.
    """
    low = text.lower()
    direction = None
    for pattern, word in _DIRECTION_WORDS:
        if pattern.search(low):
            low = pattern.sub(" ", low)
            direction = direction or word or None
    return re.sub(r"[^a-z0-9]", "", low), direction
