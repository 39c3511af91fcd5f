"""``drx garage add NAME --from-racing-line TRACK [--actions K]``: the actions clustered from the line."""

from __future__ import annotations

import pytest

from .helpers import fails_unchanged, ok, ok_json

TRACK = "reInvent2019_wide_cw"


def test_add_from_the_racing_line_shows_the_table_and_says_where_it_came_from() -> None:
    added = ok_json("garage", "add", "liner", "--from-racing-line", TRACK, "--actions", "12")
    assert added["source"] == f"racing line of {TRACK}"
    assert added["action_space_type"] == "discrete" and len(added["action_space"]) == 12
    assert {"steering_angle": 0.0, "speed": 4.0} in [
        {k: a[k] for k in ("steering_angle", "speed")} for a in added["action_space"]
    ]
    line = added["racing_line"]
    assert line["track"] == TRACK and line["actions"] == 12 and line["points"] > 100
    assert line["largest_distance"] < 0.15
    shown = ok_json("garage", "show", "liner")
    assert shown["action_space"] == added["action_space"] and shown["source"] == added["source"]
    out = ok("garage", "show", "liner").stdout
    assert f"racing line of {TRACK}" in out and "steering angle" in out
    assert len([row for row in out.splitlines() if row.strip().startswith("│")]) == 12


def test_add_prints_the_action_table_and_caps_the_speed() -> None:
    out = ok("garage", "add", "slow", "--from-racing-line", "A to Z Speedway (clockwise)",
             "--max-speed", "2.5", "--actions", "6").stdout  # fmt: skip
    assert "From the racing line of reInvent2019_wide_cw" in out and "steering angle" in out
    speeds = [a["speed"] for a in ok_json("garage", "show", "slow")["action_space"]]
    assert len(speeds) == 6 and max(speeds) == 2.5


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (("--from-racing-line", "nowhere"), ("nowhere",)),
        (("--from-racing-line", TRACK, "--actions", "1"), ("--actions 1", "2 to 30")),
        (("--from-racing-line", TRACK, "--actions", "31"), ("--actions 31", "2 to 30")),
        (("--from-racing-line", TRACK, "--actions", "2"), ("at least 3",)),
        (("--from-racing-line", TRACK, "--continuous"), ("--from-racing-line", "--continuous")),
        (
            ("--from-racing-line", TRACK, "--steering-levels", "5"),
            ("--from-racing-line", "--steering-levels"),
        ),
        (("--from-racing-line", TRACK, "--speed-levels", "3"), ("--from-racing-line", "--speed-levels")),
        (("--from-racing-line", TRACK, "--min-speed", "1"), ("--from-racing-line", "--min-speed")),
        (("--from-racing-line", TRACK, "--actions-file", "a.csv"), ("--from-racing-line", "--actions-file")),
        (("--from-racing-line", TRACK, "--from", "garage/default.toml"), ("--from", "--from-racing-line")),
        (("--from-racing-line", TRACK, "--max-speed", "5"), ("--max-speed 5", "0.1 to 4")),
        (("--from-racing-line", TRACK, "--max-steering", "0.5"), ("--max-steering 0.5", "1 to 30")),
        (("--from-racing-line", "Straight_track"), ("Straight_track", "distinct commands")),
        (("--actions", "5"), ("--actions", "--from-racing-line")),
    ],
)
def test_bad_racing_line_options_exit_2_and_store_nothing(
    args: tuple[str, ...], words: tuple[str, ...]
) -> None:
    fails_unchanged("garage", "add", "car", *args, contains=words)
