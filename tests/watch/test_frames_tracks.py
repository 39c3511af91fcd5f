"""``drx watch`` draws the track of the episode in progress (issue 40, item 5): a model that trains
on several tracks, or both ways round, changes tracks between episodes, and the page follows."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

from drx.services.models import create_model
from drx.sim.track import load_track
from drx.watch import state
from drx.watch.frames import FrameSource, driven_track
from drx.watch.live import live_dir


def _pose(folder: Path, track: str, episode: int, at: str | None = None) -> None:
    """A live pose file as a job's env writes it, on the start line of ``at`` (default ``track``)."""
    start = load_track((at or track).removesuffix("_reversed")).center[0]
    pose: dict[str, Any] = {
        "time": time.time(), "started": time.time(), "pid": 1, "source": "1-0-training",
        "mode": "training", "track": track, "episode": episode, "x": float(start[0]),
        "y": float(start[1]), "yaw": 0.0, "speed": 1.0, "steering": 0.0, "progress": 1.0, "steps": 3,
        "status": "in_progress", "reward": 1.0, "stereo": False, "path": [], "boxes": [], "bots": [],
    }  # fmt: skip
    live_dir(folder).mkdir(parents=True, exist_ok=True)
    (live_dir(folder) / "1-0-training.json").write_text(json.dumps(pose))


def test_the_pictures_follow_the_episode_s_track(tmp_path: Path) -> None:
    source = FrameSource(tmp_path, "oval")
    assert source.poll() and source.drawn == "oval"  # no pose yet: the model's first track
    _pose(tmp_path, "Oval_track", 1)
    assert source.poll() and source.drawn == "Oval_track"
    _pose(tmp_path, "oval_reversed", 2)  # the next episode drives the oval the other way
    assert source.poll() and source.drawn == "oval_reversed"
    _pose(tmp_path, "no-such-track", 3, at="oval")  # a track this registry does not know: the model's
    assert source.poll() and source.drawn == "oval"


def test_a_reversed_track_is_the_route_driven_the_other_way() -> None:
    reversed_oval = driven_track("oval_reversed")
    oval = load_track("oval")
    assert reversed_oval.name == "oval_reversed" and reversed_oval.direction != oval.direction
    assert driven_track("Oval_track").name == "Oval_track"


def test_the_page_says_every_track_and_the_one_driven() -> None:
    create_model("several", track=["oval", "Oval_track"], network="compact")
    _pose(state.model_folder("several"), "Oval_track", 1)
    snap = state.snapshot("several")
    assert snap["track"] == "oval" and snap["tracks"] == ["oval", "Oval_track"]
    assert snap["pose"]["track"] == "Oval_track"
    page = (Path(state.__file__).parent / "static" / "watch.js").read_text(encoding="utf-8")
    assert "s.pose && s.pose.track" in page and "s.tracks.join" in page
