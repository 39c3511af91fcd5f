"""The local leaderboard: stored evaluations of one track, ranked by :mod:`drx.evaluate.ranking`."""

from __future__ import annotations

from typing import Any

from sqlalchemy import select

from drx.evaluate.ranking import LapRecord, ResultRecord, check_mode, rank
from drx.registry import Evaluation, Model, session_scope


def leaderboard(
    track: str | None = None, mode: str = "best-lap", direction: str = "default"
) -> dict[str, Any]:
    """The leaderboard of ``track`` (default: the track with the most evaluations).

    :param track: the track's name.
    :param mode: ``best-lap``, ``average-lap`` or ``total-time``.
    :param direction: ``default`` or ``reverse``: races in the other direction are another leaderboard.
    :return: ``{"track", "rank", "direction", "rows": [...]}``; each row has rank, model, car,
        action space, score, best lap, its ratio to the theoretical best lap, laps, off-tracks, date.
    """
    check_mode(mode)
    records = _records(track, direction)
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
                "car": rec.extra.get("car"),
                "action_space": rec.extra.get("action_space"),
                "score": row.score,
                "fastest_lap": fastest,
                "best_lap_ratio": round(fastest / best, 3) if fastest is not None and best else None,
                "laps": f"{len(times)}/{rec.race_laps}",
                "progress": round(rec.progress, 1),
                "off_track_count": rec.off_track_count,
                "evaluation": rec.evaluation_id,
                "date": rec.created_at,
            }
        )
    return {"track": track, "rank": mode, "direction": direction, "rows": rows}


def _records(track: str | None, direction: str) -> list[ResultRecord]:
    """Every complete evaluation (of ``track`` when given) as ranking records."""
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
                    },
                )
            )
        return out
