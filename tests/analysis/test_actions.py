"""Action breakdown per section from synthetic traces (discrete and continuous cars)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from drx.analysis.actions import action_breakdown, action_labels, breakdown_figure, track_sections
from drx.sim.track import load_track
from drx.vehicle import Vehicle, default_vehicle


def _trace(track_name: str, steer: np.ndarray, speed: np.ndarray, action: np.ndarray) -> pd.DataFrame:
    track = load_track(track_name)
    n = len(steer)
    wp = np.linspace(0, len(track.center) - 2, n).astype(int)
    return pd.DataFrame({
        "episode": 0, "steps": np.arange(1, n + 1), "x": track.center[wp, 0], "y": track.center[wp, 1],
        "steering_angle": steer, "speed": speed, "action": action, "closest_waypoint": wp,
    })  # fmt: skip


def test_discrete_breakdown_follows_the_turns() -> None:
    track = load_track("oval")
    vehicle = default_vehicle()
    sections = track_sections(track)
    # Steer left (action 0: 30 deg) in the turns, straight (action 5: 0 deg / 1 m/s) elsewhere.
    trace = _trace("oval", np.zeros(800), np.zeros(800), np.zeros(800, int))
    s = track.cumulative[trace["closest_waypoint"]] % track.length
    in_turn = np.zeros(len(trace), bool)
    for sec in sections:
        if sec.kind != "straight":
            in_turn |= sec.contains(s, track.length)
    trace["action"] = np.where(in_turn, 0, 5)
    table = action_breakdown(track, vehicle, trace)
    assert list(table.columns) == action_labels(vehicle)
    for sec in sections:
        row = table.loc[sec.label]
        assert row.sum() == pytest.approx(100.0)
        assert row.iloc[0 if sec.kind != "straight" else 5] == pytest.approx(100.0)


def test_continuous_breakdown_bins_steering_and_speed() -> None:
    vehicle = Vehicle(name="c", continuous=True, steering_range=(-30.0, 30.0), speed_range=(0.5, 2.0))
    rng = np.random.default_rng(1)
    steer = rng.uniform(-30, 30, 600)
    steer[:300] = 29.0  # the first half of the lap: hard left at top speed
    speed = np.where(np.arange(600) < 300, 1.99, rng.uniform(0.5, 2.0, 600))
    trace = _trace("kidney", steer, speed, np.full(600, "[0, 0]"))
    table = action_breakdown(load_track("kidney"), vehicle, trace)
    assert len(table.columns) == 21 and table.columns[-1].startswith("+26")
    assert table.iloc[0].idxmax() == table.columns[-1]  # S1: the last bin (leftmost, fastest)
    visited = table[table.sum(axis=1) > 0]
    assert np.allclose(visited.sum(axis=1), 100.0)
    fig = breakdown_figure(load_track("kidney"), vehicle, trace, "c")
    assert len(fig.axes) == 2 + len(track_sections(load_track("kidney")))  # map, key, one per section
