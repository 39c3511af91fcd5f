"""The opponents of a head-to-model model: checked once, when the model is created or cloned.

``drx model create NAME --race-type head-to-model --opponent M [--opponent M2 ...]`` stores the
opponents' registry ids in the model's ``race`` (:class:`drx.settings.race.RaceConfig`
``opponents``); its training episodes then have them drive the other cars
(:mod:`drx.evaluate.head_to_model`). Each opponent must be another model, trained (it drives with its
best checkpoint), on the model's track in the model's direction, since the cars share one track
and drive it one way, as in a ``drx race`` (deepracer-for-cloud's head-to-head races the opponent
on the evaluated model's world, ``docs/head-to-head.md``). Every problem is one sentence
(:class:`~drx.errors.DrxError`) before anything is stored.
"""

from __future__ import annotations

from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session

from drx.errors import DrxError, NotFoundError, SettingError
from drx.registry import Checkpoint, Model, session_scope
from drx.services import tracks
from drx.settings.episodes import EpisodeSettings
from drx.settings.race import OPPONENTS_RANGE, RaceConfig, normalise_race_type
from drx.sim.catalogue import TrackEntry


def checked_race(
    race: dict[str, Any] | None, name: str, starts: EpisodeSettings, entry: TrackEntry
) -> RaceConfig:
    """The race of model ``name`` with its opponents checked and stored by id.

    :param race: :class:`RaceConfig` fields; ``opponents`` are model names (as typed) or ids (a
        stored race, a clone's parent's).
    :param name: the model being made (it cannot be its own opponent).
    :param starts: its tracks, direction and starts.
    :param entry: its first track.
    :raises DrxError: an opponent without head-to-model, more than three, unknown, itself, untrained,
        or trained on another track or direction; head-to-model on several tracks, alternating
        directions or an open track.
    """
    fields = dict(race or {})
    given = list(fields.pop("opponents", None) or ())
    kind = normalise_race_type(fields.get("race_type") or "time-trial")
    if given and kind != "head-to-model":
        raise SettingError("{field} needs {race_type} head-to-model, not {kind}.", "opponents", "race_type",
                           kind=kind)  # fmt: skip
    if kind != "head-to-model":
        return RaceConfig.from_dict(fields)
    RaceConfig.from_dict({**fields, "opponents": list(range(len(given)))})  # the count, before any look-up
    _check_schedule(starts, entry)
    with session_scope() as session:
        ids = [_opponent(session, ref, name, starts, entry).id for ref in given]
    twice = len(set(ids)) != len(ids)
    if twice:
        raise DrxError("An opponent is named twice; name each opponent once.")
    return RaceConfig.from_dict({**fields, "opponents": ids})


def opponent_names(race: RaceConfig) -> list[str]:
    """The opponents' names (``#id (removed)`` for one removed since)."""
    if not race.opponents:
        return []
    with session_scope() as session:
        found = {m.id: m.name for m in session.scalars(select(Model).where(Model.id.in_(race.opponents)))}
    return [found.get(i, f"#{i} (removed)") for i in race.opponents]


def _check_schedule(starts: EpisodeSettings, entry: TrackEntry) -> None:
    lo, hi = OPPONENTS_RANGE
    if len(starts.tracks) > 1:
        raise DrxError(
            f"A head-to-model model trains on one track, not {len(starts.tracks)}; give one --track "
            f"(its {lo}-{hi} opponents drive that track)."
        )
    if starts.alternate_direction:
        raise DrxError(
            "A head-to-model model trains in one direction, as its opponents drive; drop "
            "--alternate-direction."
        )
    if starts.tracks[0].is_open:
        raise DrxError(f"Track {entry.name!r} is not a loop; train against models on a loop.")


def _opponent(session: Session, ref: Any, name: str, starts: EpisodeSettings, entry: TrackEntry) -> Model:
    """The opponent ``ref`` (a name or an id), checked."""
    if isinstance(ref, int) and not isinstance(ref, bool):
        model = session.get(Model, ref)
        if model is None:
            raise NotFoundError(f"Opponent model #{ref} no longer exists; give the model's opponents again.")
    else:
        ref = str(ref)
        if ref == name:
            raise DrxError(f"Model {name!r} cannot be its own opponent; name another model.")
        model = session.scalar(select(Model).where(Model.name == ref))
        if model is None:
            raise NotFoundError(f"No model named {ref!r} to be an opponent (see `drx model list`).")
    if model.name == name:
        raise DrxError(f"Model {name!r} cannot be its own opponent; name another model.")
    has_checkpoint = session.scalar(select(Checkpoint.id).where(Checkpoint.model_id == model.id).limit(1))
    if has_checkpoint is None:
        raise DrxError(
            f"Opponent {model.name!r} has no checkpoint yet; train it first with `drx train {model.name}`."
        )
    if model.track_name != entry.name:
        raise DrxError(
            f"Opponent {model.name!r} was trained on {model.track_name!r}, not {entry.name!r}; "
            "name opponents trained on the model's track."
        )
    mine, theirs = _direction(starts, entry), _direction(model.episode_settings(), entry)
    if mine != theirs:
        raise DrxError(
            f"Opponent {model.name!r} drives {entry.name!r} {theirs}, the model {mine}; name opponents "
            "trained in the model's direction (or give --direction)."
        )
    return model


def _direction(starts: EpisodeSettings, entry: TrackEntry) -> str:
    """The way the first track is driven: its recorded direction, else the route's own."""
    first = starts.first
    if first is not None and first.direction:
        return str(first.direction)
    return tracks.load_entry(entry).direction
