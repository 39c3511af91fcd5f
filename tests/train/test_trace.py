"""The training trace's per-step bookkeeping."""

from __future__ import annotations

import csv
from pathlib import Path

from drx.train.trace import EpisodeTracker, TraceWriter


def test_obstacle_crash_counter_counts_the_episodes_crashes(tmp_path: Path) -> None:
    writer = TraceWriter(tmp_path, continuous=False)
    path = writer.start_iteration(0)
    for episode, status in [(0, "in_progress"), (0, "crashed"), (1, "in_progress"), (1, "crashed")]:
        writer.write(episode, 0, 1.0, status == "crashed", {"episode_status": status}, 0.0)
    writer.close()
    with path.open() as f:
        counts = [int(r["obstacle_crash_counter"]) for r in csv.DictReader(f)]
    assert counts == [0, 1, 0, 1]


def test_episode_progress_is_the_most_reached(tmp_path: Path) -> None:
    tracker = EpisodeTracker("training")
    for progress in (10.0, 30.0, 25.0):
        tracker.step(1.0, {"progress": progress, "start_fraction": 0.35})
    record = tracker.finish({"progress": 25.0, "episode_status": "off_track"}, 0, 0, 0)
    assert record.progress == 30.0 and record.start_fraction == 0.35
