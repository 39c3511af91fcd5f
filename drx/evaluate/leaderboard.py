"""The local leaderboard: the results of one track raced under one set of rules, ranked by
:mod:`drx.evaluate.ranking`.

A leaderboard is a race, as on DeepRacer on AWS: one track and one set of rules (:class:`RaceRules`:
the race type with its boxes or bots, the driving direction, the laps, the minimum laps to
qualify, the off-track penalty, the reset limit, the time cap and, with boxes or bots, the
collision penalty). Results raced under other rules are never ranked with them: a 5-lap result
is not a 3-lap one, nor a result with 5 s off-track penalties one with 2 s.

Which rules a board shows: the filters given (each a rule's value, as ``drx evaluate`` takes it)
keep the track's evaluations that match, and the rules of the most recent of those are the
board's; with no filter, the rules of the track's most recent evaluation (the race one just
ran). ``rules_of`` takes every rule from one evaluation instead. The other rule sets raced on
the track are listed with the options that show each.

Stored rules that lack a key (evaluations from before that rule existed) take its default
(:meth:`RaceRules.from_dict`): an old evaluation is a time trial without a minimum lap count.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from itertools import combinations
from typing import Any

from drx.errors import DrxError, NotFoundError, SettingError
from drx.evaluate.ranking import LapRecord, ResultRecord, check_mode, rank
from drx.evaluate.time_trial import DEFAULT_COLLISION_PENALTY, LAPS_RANGE, RaceRules
from drx.registry import quick
from drx.settings.race import normalise_race_type

# The rules a board can be chosen by, in the order a board's description and its options name them.
FILTERS = (
    "race_type",
    "direction",
    "laps",
    "min_laps",
    "off_track_penalty",
    "max_resets",
    "time_cap_minutes",
    "collision_penalty",
)
DIRECTIONS = ("default", "reverse")
NONE_WORDS = ("none", "no-limit", "unlimited")  # what --max-resets / --min-laps take for "no limit"


@dataclass(frozen=True)
class Raced:
    """One complete evaluation as the leaderboard reads it.

    :param record: its ranking record.
    :param rules: the rules it was raced under (:func:`board_rules`).
    :param track: the track's name.
    """

    record: ResultRecord
    rules: RaceRules
    track: str


def board_rules(stored: Mapping[str, Any]) -> RaceRules:
    """The rules an evaluation was raced under, from its stored ``rules`` (missing keys take their
    defaults). A time trial's collision penalty is set to the default: nothing can collide there, so
    it must not split two time trials into two leaderboards."""
    rules = RaceRules.from_dict(dict(stored))
    if not rules.race.has_objects:
        rules = replace(rules, collision_penalty=DEFAULT_COLLISION_PENALTY)
    return rules


def leaderboard(
    track: str | None = None,
    mode: str = "best-lap",
    direction: str | None = None,
    race_type: str | None = None,
    filters: Mapping[str, Any] | None = None,
    rules_of: int | None = None,
) -> dict[str, Any]:
    """The leaderboard of ``track`` under one set of rules (see the module docstring).

    :param track: the track's name (route id or display name); default the track of the most
        recent evaluation that matches the filters.
    :param mode: ``best-lap``, ``average-lap`` or ``total-time``.
    :param direction: ``default`` or ``reverse``; ``None``: any (the most recent's).
    :param race_type: ``time-trial``, ``object-avoidance`` or ``head-to-bot`` (DeepRacer's spellings
        too); ``None``: any (the most recent's).
    :param filters: other rules' values by field (:data:`FILTERS`; ``None`` for ``max_resets`` and
        ``min_laps`` means no limit / no minimum), checked by :func:`check_filters`.
    :param rules_of: take every rule from this evaluation (with no other filter).
    :return: ``{"track", "rank", "direction", "race_type", "rules", "rows", "other_rules"}``.
        ``rules`` describes the board's rules (:func:`rules_view`; ``None`` when nothing matched);
        each row has rank (``None``: did not qualify), qualified, note (why not), model, race, car,
        action space, score, fastest lap, its ratio to the theoretical best lap, laps, progress,
        off-tracks, crashes, evaluation, date; ``other_rules`` lists the other rule sets raced on
        the track, each with ``rules``, ``differs`` (what differs from this board's), ``models``,
        ``results``, ``latest`` (its newest evaluation) and ``options`` (what shows it).
    :raises DrxError: unknown mode, race type, direction or evaluation; a filter out of range; a
        track that is neither known nor raced on.
    """
    check_mode(mode)
    wanted = dict(filters or {})
    if race_type is not None:
        wanted["race_type"] = race_type
    if direction is not None:
        wanted["direction"] = direction
    wanted = check_filters(wanted)
    if rules_of is not None and wanted:
        given = ", ".join(f"{{{key}}}" for key in wanted)  # each named by its flag in the CLI
        raise SettingError(
            "{field} {value} takes every rule from that evaluation; leave out " + given + ".",
            "rules_of",
            *wanted,
            value=rules_of,
        )
    if track is not None:
        track = _check_track(track)
    raced = _raced()
    chosen: RaceRules | None = None
    if rules_of is not None:
        source = next((r for r in raced if r.record.evaluation_id == rules_of), None)
        if source is None:
            raise NotFoundError(f"No complete evaluation {rules_of}; see `drx eval list` for their ids.")
        track = track or source.track
        chosen = source.rules
    else:
        matching = [r for r in raced if matches(r.rules, wanted)]
        if track is None:  # the track of the race run last (or of any, when nothing matched)
            latest = matching[-1] if matching else (raced[-1] if raced else None)
            track = latest.track if latest is not None else None
        on_track = [r for r in matching if r.track == track]
        chosen = on_track[-1].rules if on_track else None
    here = [r for r in raced if r.track == track]
    board = [r.record for r in here if r.rules == chosen] if chosen is not None else []
    driving = _driving_direction(track) if track is not None else None
    return {
        "track": track,
        "rank": mode,
        "direction": chosen.direction if chosen else wanted.get("direction", "default"),
        "race_type": chosen.race.race_type if chosen else wanted.get("race_type", "time-trial"),
        "rules": rules_view(chosen, driving) if chosen else None,
        "rows": [_row(row) for row in rank(board, mode)],
        "other_rules": _other_rule_sets(here, chosen, driving),
    }


def parse_filters(texts: Mapping[str, str | None]) -> dict[str, Any]:
    """Rule filters typed on the command line (text by field; ``None``: not given) as values.

    Counts are whole numbers, ``max_resets`` and ``min_laps`` also take ``none`` (no limit, no
    minimum); penalties and the time cap are numbers. Ranges are :func:`check_filters`'.

    :raises SettingError: a value that is not a number of the rule's kind.
    """
    out: dict[str, Any] = {}
    for key, text in texts.items():
        if text is None:
            continue
        if key in ("race_type", "direction"):
            out[key] = text
        elif key in ("laps", "min_laps", "max_resets"):
            out[key] = read_count(text, key, none_ok=key != "laps")
        else:
            try:
                out[key] = float(text)
            except ValueError:
                raise SettingError(
                    "{field} {value!r} is not a number; use a number of {unit}, e.g. {field} {example}.",
                    key,
                    value=text,
                    unit="minutes" if key == "time_cap_minutes" else "seconds",
                    example=getattr(RaceRules(), key),
                ) from None
    return out


def read_count(text: str, field: str, none_ok: bool = True) -> int | None:
    """``text`` as a whole number (``none``: ``None`` when ``none_ok``).

    :raises SettingError: anything else, e.g. ``2.5`` laps.
    """
    word = text.strip().lower()
    if none_ok and word in NONE_WORDS:
        return None
    try:
        return int(word)
    except ValueError:
        fix = ", or none" if none_ok else ""
        raise SettingError(
            "{field} {value!r} is not a whole number; use a count such as {field} 3" + fix + ".",
            field,
            value=text,
        ) from None


def check_filters(filters: Mapping[str, Any]) -> dict[str, Any]:
    """The filters with race types in drx's spelling, after checking each value is a possible rule.

    :raises DrxError: an unknown filter or race type, a value out of the rule's range (those of
        :class:`RaceRules`), or a minimum lap count above the laps.
    """
    out = dict(filters)
    unknown = sorted(set(out) - set(FILTERS))
    if unknown:
        raise DrxError(f"Unknown rule filter(s) {', '.join(unknown)}; use {', '.join(FILTERS)}.")
    if "race_type" in out:
        out["race_type"] = normalise_race_type(out["race_type"])
    if "direction" in out and out["direction"] not in DIRECTIONS:
        raise SettingError(
            "{field} {value!r} is unknown; use default or reverse.", "direction", value=out["direction"]
        )
    lo, hi = LAPS_RANGE
    laps = out.get("laps", hi)
    if not (isinstance(laps, int) and lo <= laps <= hi):
        raise SettingError(
            "{field} {value} is out of range; use {lo} to {hi}.", "laps", value=laps, lo=lo, hi=hi
        )
    min_laps = out.get("min_laps")
    if min_laps is not None:
        if not (isinstance(min_laps, int) and 0 <= min_laps <= hi):
            raise SettingError(
                "{field} {value} is out of range; use 1 to {hi}, or none for no minimum.",
                "min_laps",
                value=min_laps,
                hi=hi,
            )
        if min_laps > laps:
            raise SettingError(
                "{field} {value} is more than {laps} {count}: no race asks for more laps than it drives; "
                "use {field} {count} or fewer.",
                "min_laps",
                "laps",
                value=min_laps,
                count=laps,
            )
        out["min_laps"] = min_laps or None  # 0: no minimum, as RaceRules stores it
    resets = out.get("max_resets")
    if resets is not None and not (isinstance(resets, int) and resets >= 0):
        raise SettingError(
            "{field} {value} is invalid; use 0 or more, or none for no limit.", "max_resets", value=resets
        )
    for key in ("off_track_penalty", "collision_penalty"):
        if key in out and not (math.isfinite(out[key]) and out[key] >= 0):
            raise SettingError("{field} {value:g} is invalid; use 0 or more seconds.", key, value=out[key])
    cap = out.get("time_cap_minutes", 1.0)
    if not (math.isfinite(cap) and 0 < cap <= 24 * 60):
        raise SettingError(
            "{field} {value:g} is invalid; use more than 0, up to 1440.", "time_cap_minutes", value=cap
        )
    return out


def matches(rules: RaceRules, filters: Mapping[str, Any]) -> bool:
    """Whether ``rules`` has every value of ``filters`` (checked ones: :func:`check_filters`). A
    collision penalty matches only races with boxes or bots (a time trial has none)."""
    for key, want in filters.items():
        if key == "race_type":
            have: Any = rules.race.race_type
        elif key == "collision_penalty" and not rules.race.has_objects:
            return False
        else:
            have = getattr(rules, key)
        if isinstance(want, float) or isinstance(have, float):
            if want is None or have is None or not math.isclose(want, have, abs_tol=1e-9):
                return False
        elif have != want:
            return False
    return True


def rules_view(rules: RaceRules, driving: str | None = None) -> dict[str, Any]:
    """The rules of a board for ``--json`` and people: every rule (``collision_penalty`` ``None`` in
    a time trial), ``race`` (its summary) with ``race_settings``, ``driving`` (``cw``/``ccw`` when
    the track's own direction is known) and ``text`` (one line, :func:`describe`)."""
    view = {
        "race_type": rules.race.race_type,
        "race": rules.race.summary(),
        "direction": rules.direction,
        "driving": _driving(rules.direction, driving),
        "laps": rules.laps,
        "min_laps": rules.min_laps,
        "off_track_penalty": rules.off_track_penalty,
        "max_resets": rules.max_resets,
        "time_cap_minutes": rules.time_cap_minutes,
        "collision_penalty": rules.collision_penalty if rules.race.has_objects else None,
        "race_settings": rules.race.to_dict(),
    }
    view["text"] = describe(rules, driving)
    return view


def describe(rules: RaceRules, driving: str | None = None, only: Sequence[str] | None = None) -> str:
    """The rules in one line for people: ``time-trial, ccw, 3 laps (min 3 to qualify), off-track
    2 s, no reset limit`` (the time cap only when it is not the default 20 min).

    :param driving: the track's own direction (``cw``/``ccw``), to name the race's.
    :param only: name only these rules (:data:`FILTERS`; ``race_type`` names the race with its
        boxes or bots): what sets another board apart from this one.
    """
    keys = FILTERS if only is None else only
    default = RaceRules()
    parts = []
    for key in keys:
        if key == "race_type":
            parts.append(rules.race.summary())
        elif key == "direction":
            parts.append(_driving(rules.direction, driving) or "track's direction")
            if rules.direction == "reverse":
                parts[-1] = f"{parts[-1]} (reversed)" if driving else "reversed"
        elif key == "laps":
            wanted = "no minimum" if rules.min_laps is None else f"min {rules.min_laps} to qualify"
            parts.append(f"{rules.laps} laps" + (f" ({wanted})" if only is None else ""))
        elif key == "min_laps" and only is not None:
            parts.append("no minimum laps" if rules.min_laps is None else f"min {rules.min_laps} laps")
        elif key == "off_track_penalty":
            parts.append(f"off-track {rules.off_track_penalty:g} s")
        elif key == "max_resets":
            parts.append("no reset limit" if rules.max_resets is None else f"max {rules.max_resets} resets")
        elif key == "time_cap_minutes" and (only or rules.time_cap_minutes != default.time_cap_minutes):
            parts.append(f"time cap {rules.time_cap_minutes:g} min")
        elif key == "collision_penalty" and rules.race.has_objects:
            parts.append(f"collision {rules.collision_penalty:g} s")
    return ", ".join(parts)


def _driving(direction: str, track_direction: str | None) -> str | None:
    """``cw`` / ``ccw``: the way a race goes round the track, when the track's own way is known."""
    if track_direction not in ("cw", "ccw"):
        return None
    if direction == "reverse":
        return "cw" if track_direction == "ccw" else "ccw"
    return track_direction


def _driving_direction(track: str) -> str | None:
    """The track's own direction (``cw``, ``ccw``), or ``None`` when its route is gone or open (no
    NumPy once ``drx track list`` has cached the shipped routes' facts)."""
    from drx.services.tracks import find_track, route_direction

    try:
        return route_direction(find_track(track))
    except (DrxError, OSError, ValueError):  # an imported track removed since: its results still rank
        return None


def _row(row: Any) -> dict[str, Any]:
    """A ranked row for ``--json`` and the table."""
    rec: ResultRecord = row.record
    best = rec.extra.get("best_lap")
    times = rec.complete_times
    fastest = min(times) if times else None
    note = None
    if not rec.qualified:
        done = rec.consecutive_laps
        laps = f"{done} complete lap{'' if done == 1 else 's'} in a row"
        note = f"did not qualify: {laps}, the rules ask for {rec.min_laps}"
    return {
        "rank": row.rank,
        "qualified": rec.qualified,
        "note": note,
        "model": rec.model,
        "race": rec.extra.get("race"),
        "car": rec.extra.get("car"),
        "action_space": rec.extra.get("action_space"),
        "score": row.score,
        "fastest_lap": fastest,
        "best_lap_ratio": round(fastest / best, 3) if fastest is not None and best else None,
        "laps": f"{len(times)}/{rec.race_laps}",
        "progress": round(rec.progress, 1),
        "off_track_count": rec.off_track_count,
        "crash_count": rec.extra.get("crash_count", 0),
        "evaluation": rec.evaluation_id,
        "date": rec.created_at,
    }


def _other_rule_sets(
    here: list[Raced], chosen: RaceRules | None, driving: str | None
) -> list[dict[str, Any]]:
    """The rule sets raced on the track other than the board's, the most recently raced first, each
    with the options of ``drx leaderboard`` that show it."""
    groups: dict[RaceRules, list[Raced]] = {}
    for r in here:
        groups.setdefault(r.rules, []).append(r)
    default = here[-1].rules if here else None  # the board `drx leaderboard --track T` shows
    out = []
    order = {id(r): i for i, r in enumerate(here)}  # `here` runs oldest first
    for rules, results in sorted(groups.items(), key=lambda kv: -order[id(kv[1][-1])]):
        if rules == chosen:
            continue
        differs = [k for k in FILTERS if _differs(rules, chosen, k)] if chosen else list(FILTERS)
        out.append(
            {
                "rules": rules_view(rules, driving),
                "differs": describe(rules, driving, only=differs) if chosen else describe(rules, driving),
                "models": len({r.record.model for r in results}),
                "results": len(results),
                "latest": results[-1].record.evaluation_id,
                "options": _options_for(rules, results[-1], here, default),
            }
        )
    return out


def _differs(rules: RaceRules, other: RaceRules | None, key: str) -> bool:
    """Whether two rule sets differ in ``key`` (``race_type``: the race with its boxes or bots)."""
    if other is None:
        return True
    if key == "race_type":
        return rules.race != other.race
    if key == "collision_penalty" and not (rules.race.has_objects or other.race.has_objects):
        return False
    return bool(getattr(rules, key) != getattr(other, key))


def _options_for(rules: RaceRules, latest: Raced, here: list[Raced], default: RaceRules | None) -> str:
    """The fewest options (up to three) that show ``rules``' board, i.e. whose most recent matching
    evaluation on the track was raced under ``rules``, trying first the rules that differ from the
    track's default board; else ``--rules-of`` its newest evaluation (also for a difference no option
    names, such as where the boxes stand). ``""``: the default board itself, no option needed."""
    if rules == default:
        return ""
    differing = [k for k in FILTERS if _differs(rules, default, k)]
    keys = differing + [k for k in FILTERS if k not in differing]
    for size in (1, 2, 3):
        for chosen in combinations(keys, size):
            picked = {k: _filter_value(rules, k) for k in chosen}
            matching = [r for r in here if matches(r.rules, picked)]
            if matching and matching[-1].rules == rules:  # what `drx leaderboard` picks with them
                return " ".join(_option_text(k, v) for k, v in picked.items())
    return f"--rules-of {latest.record.evaluation_id}"


def _filter_value(rules: RaceRules, key: str) -> Any:
    return rules.race.race_type if key == "race_type" else getattr(rules, key)


def _option_text(key: str, value: Any) -> str:
    """A filter as ``drx leaderboard`` options (the CLI's words; ``flags.py`` has the same)."""
    if key == "direction":
        return "--reverse" if value == "reverse" else "--no-reverse"
    flag = "--" + key.replace("_", "-")
    if value is None:
        return f"{flag} none"
    return f"{flag} {value:g}" if isinstance(value, float) else f"{flag} {value}"


def _check_track(track: str) -> str:
    """The canonical name of ``track`` (a route id or display name, as ``--track`` takes it), or the
    name itself when only evaluations know it (an imported track removed since: its results still
    rank).

    :raises NotFoundError: neither a known track nor one any evaluation raced on.
    """
    from drx.services.tracks import find_track

    try:
        return find_track(track).name
    except NotFoundError as exc:
        raced = quick.raced_track_names()
        if raced is None:
            from sqlalchemy import select

            from drx.registry import Evaluation, session_scope

            with session_scope() as session:
                raced = set(session.scalars(select(Evaluation.track_name)))
        if track in raced:
            return track
        raise exc from None


def _raced() -> list[Raced]:
    """Every complete evaluation, oldest first (by time, then id), with the rules it was raced under
    (read at once from a current SQLite registry, :mod:`drx.registry.quick`)."""
    rows = quick.complete_evaluations()
    if rows is not None:
        return [_raced_one(ev, name) for ev, name in rows]
    from sqlalchemy import select

    from drx.registry import Evaluation, Model, session_scope

    with session_scope() as session:
        query = select(Evaluation, Model.name).join(Model, Model.id == Evaluation.model_id)
        query = query.where(Evaluation.status == "complete")
        ordered = query.order_by(Evaluation.created_at, Evaluation.id)
        return [_raced_one(ev, name) for ev, name in session.execute(ordered).all()]


def _raced_one(ev: Any, name: str) -> Raced:
    """One complete evaluation (a row of the table or of :mod:`drx.registry.quick`, its laps in order)."""
    stored = dict(ev.rules or {})
    rules = board_rules(stored)
    return Raced(
        record=ResultRecord(
            evaluation_id=ev.id,
            model=name,
            race_laps=rules.laps,
            laps=tuple(LapRecord(time=lap.time, progress=lap.progress) for lap in ev.laps),
            created_at=ev.created_at,
            off_track_count=ev.off_track_count,
            min_laps=rules.min_laps,
            extra={
                "car": stored.get("car"),
                "action_space": stored.get("action_space"),
                "best_lap": stored.get("best_lap"),
                "race": rules.race.summary(),
                "crash_count": ev.crash_count,
            },
        ),
        rules=rules,
        track=ev.track_name,
    )
