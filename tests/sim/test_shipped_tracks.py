"""Every track drx ships (DeepRacer's routes and drx's own) works as any track does: it loads by
name, its reward params at the start line are sane, the camera sees it, and an evaluation episode
steps on it. A route added to ``drx/tracks/deepracer`` (tools/sync_deepracer_routes.py) that does
not load fails here."""

from __future__ import annotations

import numpy as np
import pytest

from drx.sim.catalogue import resolve, shipped_tracks
from drx.sim.env import DeepRacerEnv
from drx.sim.track import load_track, route_facts
from drx.sim.track_names import NO_PUBLIC_NAME, display_name
from drx.vehicle import default_vehicle

SHIPPED = shipped_tracks()
STEPS = 5


def test_drx_ships_deepracer_routes_and_its_own_tracks() -> None:
    sources = {e.source for e in SHIPPED}
    assert sources == {"deepracer", "drx"}
    assert len({e.name for e in SHIPPED}) == len(SHIPPED), "a route id may be shipped once"
    for entry in SHIPPED:
        if entry.source == "deepracer":
            assert entry.display_name == display_name(entry.name)  # None: "no public display name"
            assert entry.display_text == (entry.display_name or NO_PUBLIC_NAME)


@pytest.mark.parametrize("entry", SHIPPED, ids=lambda e: e.name)
def test_a_shipped_track_loads_and_drives(entry: object) -> None:
    from drx.sim.catalogue import TrackEntry

    assert isinstance(entry, TrackEntry)
    track = load_track(entry.name)  # by name, as every command finds it
    assert track.name == entry.name and track.length > 1.0
    if entry.display_name:  # the display name finds it too
        assert resolve(entry.display_name, SHIPPED) == entry
    facts = route_facts(entry.path)  # what `drx track list` shows, without building the track
    assert facts["length"] == pytest.approx(track.length, abs=1e-9)
    assert facts["direction"] == track.direction and facts["closed"] == track.closed

    env = DeepRacerEnv(track=track, vehicle=default_vehicle(), mode="evaluation", deterministic=True)
    frame, info = env.reset(seed=0)
    params = info["params"]
    # the start line: a sliver of progress (the reference point's lead), on the road, near the centre
    assert 0.0 <= params["progress"] < 100 * 0.3 / track.length
    assert params["all_wheels_on_track"] and not params["is_offtrack"]
    assert 0.3 < params["track_width"] < 2.0
    assert params["distance_from_center"] < 0.1
    prev, nxt = params["closest_waypoints"]
    n = len(params["waypoints"])
    assert 0 <= prev < n and 0 <= nxt < n and nxt in (prev + 1, 0)
    assert prev <= 2  # the start line is row 0
    # the camera sees the road: a grey frame with contrast, not a constant picture
    assert frame.shape == (120, 160, 1) and frame.dtype == np.uint8
    assert float(frame.std()) > 5.0
    # a few evaluation steps straight ahead at the car's slowest speed
    straight = min(
        range(env.vehicle.n_actions),
        key=lambda i: (abs(env.vehicle.actions[i].steering_angle), env.vehicle.actions[i].speed),
    )
    for step in range(1, STEPS + 1):
        frame, reward, terminated, truncated, info = env.step(straight)
        assert np.isfinite(reward) and info["params"]["steps"] == step
        assert not truncated
        if terminated:
            break
    assert info["progress"] > params["progress"]
