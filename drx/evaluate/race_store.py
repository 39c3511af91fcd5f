"""Head-to-head races in the registry: store one (:func:`store_race`), read them back
(:func:`list_races`), and the board of a track ranked by Elo rating (:func:`head_to_head_board`).

**Why Elo.** A race orders two to four cars; each pair of cars in it is one game the one placed
higher won (a finished car beats an unfinished one; unfinished cars are ordered by race distance,
so every pair has a winner). Elo's rating (A. Elo, *The Rating of Chessplayers, Past and
Present*, 1978; the logistic form FIDE and most leagues use) turns a series of such games into one
number per model: model A is expected to beat B with probability ``1 / (1 + 10^((R_B - R_A) /
400))``, and after a game each rating moves by ``K * (result - expected)``. drx starts every model at
:data:`START_RATING` and uses :data:`K_FACTOR`; a race of ``n`` cars is its ``n(n-1)/2`` pairs, each
with ``K / (n - 1)`` so that a model's rating moves as much per race whatever the field's size (the
usual pairwise extension of Elo to multi-player games). Races are replayed oldest first, so a
board is the same whenever it is read. openskill (a well-kept Weng-Lin rating library) and
trueskill would fit too, but they are a new runtime dependency for a formula of a few lines, and
their uncertainty term matters little next to how many races a local board sees.
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass, field
from datetime import datetime
from typing import Any

from sqlalchemy import select

from drx.evaluate.head_to_head import RaceResult
from drx.registry import Model, Race, RaceEntry, session_scope, utcnow
from drx.services.tracks import find_track

START_RATING = 1500.0
K_FACTOR = 32.0


def store_race(
    prepared: Any, result: RaceResult, bracket: str | None = None, bracket_round: int | None = None,
    video: str | None = None,
) -> int:  # fmt: skip
    """Write a race and its cars in one transaction; returns the race's id.

    :param prepared: the :class:`~drx.evaluate.race_service.PreparedRace` it ran.
    """
    racers = {r.name: r for r in prepared.racers}
    rules = result.rules.to_dict()
    rules["direction_name"] = prepared.direction
    with session_scope() as session:
        race = Race(
            track_name=prepared.track_name, rules=rules, ended=result.ended, race_time=result.race_time,
            seed=result.seed, bracket=bracket, bracket_round=bracket_round, video=video, created_at=utcnow(),
        )  # fmt: skip
        for car in result.cars:
            racer = racers[car.name]
            trace = prepared.traces.get(car.name)
            race.entries.append(
                RaceEntry(
                    model_id=racer.model_id, checkpoint_id=racer.checkpoint.row_id, start_index=car.index,
                    place=car.place, status=car.status, laps=car.laps, lap_times=list(car.lap_times),
                    time=car.time, progress=car.progress, collisions=car.collisions, crashes=car.crashes,
                    off_track_count=car.off_tracks, penalty_seconds=car.penalty_seconds,
                    trace=None if trace is None else str(trace),
                )
            )  # fmt: skip
        session.add(race)
        session.flush()
        return int(race.id)


def list_races(track: str | None = None) -> list[dict[str, Any]]:
    """Every stored race (on ``track``), oldest first: id, track, time, ended, and its cars in order."""
    if track is not None:
        track = find_track(track).name
    with session_scope() as session:
        query = select(Race).order_by(Race.id)
        if track is not None:
            query = query.where(Race.track_name == track)
        names = {int(i): str(n) for i, n in session.execute(select(Model.id, Model.name))}
        out = []
        for race in session.scalars(query):
            out.append({
                "id": race.id, "track": race.track_name, "created_at": race.created_at,
                "ended": race.ended, "race_time": race.race_time, "bracket": race.bracket,
                "round": race.bracket_round, "rules": dict(race.rules or {}),
                "cars": [
                    {"model": names.get(e.model_id, "?"), "place": e.place, "status": e.status,
                     "laps": e.laps, "time": e.time, "progress": e.progress,
                     "collisions": e.collisions, "crashes": e.crashes}
                    for e in sorted(race.entries, key=lambda e: e.place)
                ],
            })  # fmt: skip
        return out


@dataclass
class BoardRow:
    """One model on the head-to-head board."""

    model: str
    rating: float = START_RATING
    races: int = 0
    wins: int = 0
    last_place: int = 0
    last_field: int = 0
    last_against: list[str] = field(default_factory=list)
    last_date: datetime | None = None

    def to_dict(self) -> dict[str, Any]:
        """A JSON-friendly dict (``last`` is e.g. ``1st of 2 vs b``)."""
        return {
            "model": self.model, "rating": round(self.rating, 1), "races": self.races, "wins": self.wins,
            "last": last_result(self.last_place, self.last_field, self.last_against),
            "last_date": self.last_date,
        }  # fmt: skip


def expected(rating: float, other: float) -> float:
    """Elo's expected score of ``rating`` against ``other`` (the logistic curve, 400-point scale)."""
    return 1.0 / (1.0 + 10.0 ** ((other - rating) / 400.0))


def rate(orders: list[list[str]]) -> dict[str, float]:
    """Elo ratings after races given as finishing orders (first place first), oldest first."""
    ratings: dict[str, float] = defaultdict(lambda: START_RATING)
    for order in orders:
        n = len(order)
        if n < 2:
            continue
        k = K_FACTOR / (n - 1)
        before = {m: ratings[m] for m in order}
        change = dict.fromkeys(order, 0.0)
        for i, winner in enumerate(order):
            for loser in order[i + 1 :]:
                e = expected(before[winner], before[loser])
                change[winner] += k * (1.0 - e)
                change[loser] -= k * (1.0 - e)
        for m in order:
            ratings[m] = before[m] + change[m]
    return dict(ratings)


def head_to_head_board(track: str | None = None) -> dict[str, Any]:
    """The head-to-head board of a track (default: the track raced last): one row per model, by
    rating, with its wins (first places), races and last result.

    :raises NotFoundError: an unknown track (from the track catalogue).
    """
    races = list_races(track)
    if track is None and races:
        track = races[-1]["track"]
        races = [r for r in races if r["track"] == track]
    elif track is not None:
        track = find_track(track).name
    if track is None:
        return {"track": None, "race_type": "head-to-head", "rating": "elo", "rows": [], "races": 0}
    rows: dict[str, BoardRow] = {}
    for race in races:
        order = [c["model"] for c in race["cars"]]
        for car in race["cars"]:
            row = rows.setdefault(car["model"], BoardRow(car["model"]))
            row.races += 1
            row.wins += car["place"] == 1
            row.last_place, row.last_field = car["place"], len(order)
            row.last_against = [m for m in order if m != car["model"]]
            row.last_date = race["created_at"]
    for name, rating in rate([[c["model"] for c in r["cars"]] for r in races]).items():
        rows[name].rating = rating
    ranked = sorted(rows.values(), key=lambda r: (-r.rating, -r.wins, r.model))
    return {
        "track": track, "race_type": "head-to-head", "rating": "elo", "k_factor": K_FACTOR,
        "start_rating": START_RATING, "races": len(races),
        "rows": [{"rank": i, **r.to_dict()} for i, r in enumerate(ranked, start=1)],
    }  # fmt: skip


def last_result(place: int, field_size: int, against: list[str]) -> str:
    """``1st of 2 vs b`` (``""`` before any race)."""
    if not place:
        return ""
    suffix = {1: "st", 2: "nd", 3: "rd"}.get(place, "th")
    return f"{place}{suffix} of {field_size} vs {', '.join(against)}"



def best_time_trial_laps(track_name: str, models: list[str]) -> dict[str, float]:
    """[s] each model's fastest time-trial lap on a track (the bracket's seeding); models without one
    are left out."""
    from drx.registry import Evaluation

    with session_scope() as session:
        rows = session.execute(
            select(Model.name, Evaluation.fastest_lap, Evaluation.rules)
            .join(Evaluation, Evaluation.model_id == Model.id)
            .where(Model.name.in_(models), Evaluation.track_name == track_name)
        ).all()
    best: dict[str, float] = {}
    for name, lap, rules in rows:
        if lap is None or (rules or {}).get("race_type", "time_trial") != "time_trial":
            continue
        best[name] = min(best.get(name, lap), lap)
    return best
