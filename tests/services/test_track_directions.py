"""A track and a direction resolved once (``drx.sim.catalogue`` picks the route, ``drx.services.tracks``
says whether it is driven reversed)."""

from __future__ import annotations

import pytest

from drx.errors import DrxError, NotFoundError, SettingError
from drx.services.tracks import find_directed
from drx.sim.catalogue import find, shipped_tracks

TWO_WAY = sorted(e.name[: -len("_cw")] for e in shipped_tracks() if e.name.endswith("_cw"))


def test_the_shipped_two_way_tracks() -> None:
    assert len(TWO_WAY) >= 25 and "reInvent2019_wide" in TWO_WAY


def test_every_two_way_track_resolves_to_its_route_for_each_direction() -> None:
    """Whichever of its routes is named, a direction gives that direction's route, never a reversed one."""
    entries = shipped_tracks()
    for base in TWO_WAY:
        for named in (f"{base}_cw", f"{base}_ccw"):
            for direction in ("cw", "ccw"):
                found = find(named, entries, direction)
                assert found is not None and found.name == f"{base}_{direction}", (named, direction)
    for direction in ("cw", "ccw"):  # and the route's own direction agrees: not driven reversed
        directed = find_directed("reInvent2019_wide_cw", direction)
        assert (directed.entry.name, directed.direction, directed.reverse) == (
            f"reInvent2019_wide_{direction}", direction, False
        )  # fmt: skip


def test_a_one_way_track_is_driven_reversed_the_other_way() -> None:
    own = find_directed("reinvent_base")
    assert (own.entry.name, own.direction, own.reverse) == ("reinvent_base", "ccw", False)
    other = find_directed("re:Invent 2018", "Clockwise")  # its display name, a typed direction
    assert (other.entry.name, other.direction, other.reverse) == ("reinvent_base", "cw", True)
    assert other.training_track().label == "reinvent_base (clockwise, reversed)"


def test_a_display_name_of_two_routes_needs_no_direction_word_when_a_direction_is_given() -> None:
    with pytest.raises(DrxError, match="fits several tracks"):
        find_directed("Forever Raceway")
    assert find_directed("Forever Raceway", "ccw").entry.name == "2024_reinvent_champ_ccw"


def test_directions_that_cannot_be() -> None:
    with pytest.raises(SettingError, match="'Straight_track' is open") as info:
        find_directed("Straight_track", "cw")
    assert info.value.field == "direction"
    assert find_directed("Straight_track").direction == "-"
    with pytest.raises(SettingError, match="direction 'north' is unknown"):
        find_directed("oval", "north")
    with pytest.raises(NotFoundError, match="No track named"):
        find_directed("no-such-track", "cw")
