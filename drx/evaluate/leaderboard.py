"""The local leaderboard: evaluations of one track and race type, ranked by :mod:`drx.evaluate.ranking`.

Each race type is its own leaderboard (a lap round boxes is not a time trial's lap), as each
driving direction is; evaluations stored before race types are time trials.
"""

from __future__ import annotations

from typing import Any

from sqlalchemy import select

from drx.errors import NotFoundError
from drx.evaluate.ranking import LapRecord, ResultRecord, check_mode, rank
from drx.registry import Evaluation, Model, session_scope
from drx.settings.race import RaceConfig, normalise_race_type


def leaderboard(
    track: str | None = None,
    mode: str = "best-lap",
    direction: str = "default",
    race_type: str = "time-trial",
) -> dict[str, Any]:
    """The leaderboard of ``track`` (default: the track with the most evaluations of the race type).

    :param track: the track's name.
    :param mode: ``best-lap``, ``average-lap`` or ``total-time``.
    :param direction: ``default`` or ``reverse``: races in the other direction are another leaderboard.
    :param race_type: ``time-trial``, ``object-avoidance`` or ``head-to-bot`` (DeepRacer's spellings
        too): each race type is another leaderboard.
    :return: ``{"track", "rank", "direction", "race_type", "rows": [...]}``; each row has rank, model,
        race, car, action space, score, best lap, its ratio to the theoretical best lap, laps,
        off-tracks, crashes, date.
    :raises DrxError: unknown mode or race type, or a track that is neither known nor raced on.
    """
    check_mode(mode)
    race_type = normalise_race_type(race_type)
    if track is not None:
        track = _check_track(track)
    records = _records(track, direction, race_type)
    if track is None:
        counts: dict[str, int] = {}
        for rec in records:
            counts[rec.extra["track"]] = counts.get(rec.extra["track"], 0) + 1
        track = max(sorted(counts), key=lambda t: counts[t]) if counts else None
        records = [r for r in records if r.extra["track"] == track]
    rows = []
    for row in rank(records, mode):
        rec = row.record
        best = rec.extra.get("best_lap")
        times = rec.complete_times
        fastest = min(times) if times else None
        rows.append(
            {
                "rank": row.rank,
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
        )
    return {"track": track, "rank": mode, "direction": direction, "race_type": race_type, "rows": rows}


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
        with session_scope() as session:
            raced = sorted(set(session.scalars(select(Evaluation.track_name))))
        if track in raced:
            return track
        raise exc from None


def _records(track: str | None, direction: str, race_type: str) -> list[ResultRecord]:
    """Every complete evaluation of the race type (and of ``track`` when given) as ranking records."""
    with session_scope() as session:
        query = select(Evaluation, Model.name).join(Model, Model.id == Evaluation.model_id)
        query = query.where(Evaluation.status == "complete")
        if track is not None:
            query = query.where(Evaluation.track_name == track)
        out = []
        for ev, name in session.execute(query.order_by(Evaluation.id)).all():
            rules = dict(ev.rules or {})
            if rules.get("direction", "default") != direction:
                continue
            race = RaceConfig.from_dict(rules.get("race"))
            if race.race_type != race_type:
                continue
            out.append(
                ResultRecord(
                    evaluation_id=ev.id,
                    model=name,
                    race_laps=int(rules.get("laps") or len(ev.laps) or 1),
                    laps=tuple(LapRecord(time=lap.time, progress=lap.progress) for lap in ev.laps),
                    created_at=ev.created_at,
                    off_track_count=ev.off_track_count,
                    extra={
                        "track": ev.track_name,
                        "car": rules.get("car"),
                        "action_space": rules.get("action_space"),
                        "best_lap": rules.get("best_lap"),
                        "race": race.summary(),
                        "crash_count": ev.crash_count,
                    },
                )
            )
        return out
