"""The training trace's per-step bookkeeping."""

from __future__ import annotations

import csv
from pathlib import Path

from drx.train.trace import TraceWriter


def test_obstacle_crash_counter_counts_the_episodes_crashes(tmp_path: Path) -> None:
    writer = TraceWriter(tmp_path, continuous=False)
    path = writer.start_iteration(0)
    for episode, status in [(0, "in_progress"), (0, "crashed"), (1, "in_progress"), (1, "crashed")]:
        writer.write(episode, 0, 1.0, status == "crashed", {"episode_status": status}, 0.0)
    writer.close()
    with path.open() as f:
        counts = [int(r["obstacle_crash_counter"]) for r in csv.DictReader(f)]
    assert counts == [0, 1, 0, 1]

