"""Where and which way training episodes start, and on which tracks (``drx.settings.episodes``)."""

from __future__ import annotations

import math

import pytest

from drx.errors import SettingError
from drx.settings.episodes import EpisodeSettings, TrainingTrack, parse_direction, start_fraction

OVAL = TrainingTrack("oval", "ccw")
KIDNEY = TrainingTrack("kidney", "cw")
STRAIGHT = TrainingTrack("Straight_track", "-")


def test_defaults_are_deepracers() -> None:
    """rollout_worker.py: CHANGE_START_POSITION true, ALTERNATE_DRIVING_DIRECTION false,
    ROUND_ROBIN_ADVANCE_DIST 0.05, START_POSITION_OFFSET 0.0."""
    s = EpisodeSettings((OVAL,))
    assert (s.change_start_position, s.alternate_direction) == (True, False)
    assert (s.round_robin_advance, s.start_position_offset, s.direction) == (0.05, 0.0, None)
    assert [s.start(g).fraction for g in range(22)] == pytest.approx([(0.05 * g) % 1.0 for g in range(22)])
    assert {s.start(g).track for g in range(5)} == {0} and not any(s.start(g).reverse for g in range(5))


def test_round_robin_with_advance_and_offset() -> None:
    s = EpisodeSettings((OVAL,), round_robin_advance=0.3, start_position_offset=0.25)
    assert [s.start(g).fraction for g in range(5)] == pytest.approx([0.25, 0.55, 0.85, 0.15, 0.45])
    fixed = EpisodeSettings((OVAL,), change_start_position=False, start_position_offset=0.4)
    assert [fixed.start(g).fraction for g in range(4)] == pytest.approx([0.4] * 4)
    assert start_fraction(3, 0.1, 0.95) == pytest.approx(0.25)


def test_alternate_direction_flips_every_episode() -> None:
    s = EpisodeSettings((OVAL,), alternate_direction=True)
    assert [s.start(g).reverse for g in range(6)] == [False, True, False, True, False, True]
    # a track driven reversed (its direction has no route of its own) alternates from reversed
    turned = EpisodeSettings((TrainingTrack("oval", "cw", reverse=True),), alternate_direction=True)
    assert [turned.start(g).reverse for g in range(4)] == [True, False, True, False]
    # the start advances whichever way the episode drives, as simapp's finish_episode does
    assert [s.start(g).fraction for g in range(3)] == pytest.approx([0.0, 0.05, 0.1])


def test_several_tracks_take_turns_each_with_its_own_round_robin() -> None:
    s = EpisodeSettings((OVAL, KIDNEY), alternate_direction=True)
    plan = [s.start(g) for g in range(6)]
    assert [p.track for p in plan] == [0, 1, 0, 1, 0, 1]
    assert [p.round for p in plan] == [0, 0, 1, 1, 2, 2]
    assert [p.fraction for p in plan] == pytest.approx([0.0, 0.0, 0.05, 0.05, 0.1, 0.1])
    assert [p.reverse for p in plan] == [False, False, True, True, False, False]
    assert s.track_names == ["oval", "kidney"] and s.first == OVAL


@pytest.mark.parametrize("advance", [0, 1, 1.5, -0.05, math.nan, "x", True])
def test_round_robin_advance_out_of_range(advance: object) -> None:
    with pytest.raises(SettingError, match="round_robin_advance .* is out of range; use a fraction") as info:
        EpisodeSettings((OVAL,), round_robin_advance=advance)  # type: ignore[arg-type]
    assert info.value.field == "round_robin_advance"


@pytest.mark.parametrize("offset", [1, 1.2, -0.1])
def test_start_position_offset_out_of_range(offset: float) -> None:
    with pytest.raises(SettingError, match=f"start_position_offset {offset} is out of range"):
        EpisodeSettings((OVAL,), start_position_offset=offset)
    assert EpisodeSettings((OVAL,), start_position_offset=0).start_position_offset == 0.0


def test_tracks_that_do_not_fit_together() -> None:
    with pytest.raises(SettingError, match="track 'oval' is given twice") as twice:
        EpisodeSettings((OVAL, KIDNEY, OVAL))
    assert twice.value.field == "track"
    with pytest.raises(SettingError, match="'Straight_track' is open and 'oval' is a loop") as mixed:
        EpisodeSettings((STRAIGHT, OVAL))
    assert mixed.value.field == "track"
    with pytest.raises(SettingError, match="alternate_direction needs a loop") as alternate:
        EpisodeSettings((STRAIGHT,), alternate_direction=True)
    assert alternate.value.field == "alternate_direction"
    assert EpisodeSettings((STRAIGHT,)).start(1).fraction == pytest.approx(0.05)  # open ones round-robin too


def test_overridden_keeps_what_was_not_given_and_refuses_an_advance_that_does_nothing() -> None:
    parent = EpisodeSettings((OVAL,), alternate_direction=True, round_robin_advance=0.1)
    clone = parent.overridden({"alternate_direction": None, "start_position_offset": 0.5})
    assert (clone.alternate_direction, clone.round_robin_advance, clone.start_position_offset) == (
        True, 0.1, 0.5
    )  # fmt: skip
    with pytest.raises(SettingError, match="round_robin_advance 0.2 does nothing while change_start_posi"):
        parent.overridden({"change_start_position": False, "round_robin_advance": 0.2})
    # new tracks and the options are checked together: an open track without the parent's alternation
    opened = parent.overridden({"alternate_direction": False}, tracks=(STRAIGHT,))
    assert opened.track_names == ["Straight_track"] and not opened.alternate_direction


def test_json_round_trip_and_models_from_before() -> None:
    s = EpisodeSettings((TrainingTrack("reinvent_base", "cw", True), KIDNEY), "cw", True, False, 0.1, 0.3)
    assert EpisodeSettings.from_dict(s.to_dict()) == s
    old = EpisodeSettings.from_dict(None, track="oval")
    assert old.tracks == (TrainingTrack("oval"),) and old == EpisodeSettings((TrainingTrack("oval"),))
    assert old.first is not None and old.first.label == "oval"
    assert s.tracks[0].label == "reinvent_base (clockwise, reversed)"


@pytest.mark.parametrize(
    ("typed", "direction"),
    [("cw", "cw"), ("Clockwise", "cw"), ("CCW", "ccw"), ("counterclockwise", "ccw"),
     ("counter-clockwise", "ccw"), ("Counter Clockwise", "ccw"), (None, None)],
)  # fmt: skip
def test_direction_words(typed: str | None, direction: str | None) -> None:
    assert parse_direction(typed) == direction


def test_an_unknown_direction_names_the_word_and_the_choices() -> None:
    with pytest.raises(SettingError, match="direction 'left' is unknown; use cw .* or ccw") as info:
        parse_direction("left")
    assert info.value.field == "direction"
