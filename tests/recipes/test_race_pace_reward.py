"""The race-pace recipe's reward file: DeepRacer's params only, the line paid, a slower lap not paid more."""

from __future__ import annotations

import math
from typing import Any

import pytest

from drx.recipes.race_pace import CONTINUOUS, DISCRETE, build_recipe
from drx.services.rewards import compile_reward
from drx.services.tracks import find_directed, load_entry


@pytest.fixture(scope="module")
def recipe() -> Any:
    directed = find_directed("reInvent2019_wide_cw")
    return build_recipe("race-pace", load_entry(directed.entry), "reInvent2019_wide_cw", "6", "m")


def _module(recipe: Any) -> dict[str, Any]:
    namespace: dict[str, Any] = {}
    exec(compile(recipe.reward_code, recipe.reward_filename, "exec"), namespace)  # drx wrote it: trusted
    return namespace


def _params(x: float, y: float, speed: float, index: int, progress: float, steps: int) -> dict[str, Any]:
    """Only DeepRacer's documented params the file may read (a KeyError if it read another)."""
    return {
        "x": x, "y": y, "speed": speed, "track_width": 1.07, "closest_waypoints": [index - 1, index],
        "progress": progress, "steps": steps, "all_wheels_on_track": True, "is_offtrack": False,
    }  # fmt: skip


def test_the_file_loads_as_a_reward_and_pays_the_line_at_its_speed(recipe: Any) -> None:
    reward = compile_reward(recipe.reward_code, recipe.reward_filename)
    namespace = _module(recipe)
    line = namespace["RACING_LINE"]
    i = len(line) // 3
    x, y, command = line[i]
    v = namespace["SPEED_SHARE"] * command
    held = reward(_params(x, y, v, i, 33.0, 25))
    assert held > 1.0
    (ax, ay, _), (bx, by, _) = line[i - 1], line[i + 1]
    norm = math.hypot(bx - ax, by - ay)
    across = (-(by - ay) / norm * 0.3, (bx - ax) / norm * 0.3)  # 30 cm square to the line
    assert reward(_params(x + across[0], y + across[1], v, i, 33.0, 25)) < 0.8 * held  # off the line
    assert reward(_params(x, y, max(0.1, v - 0.8), i, 33.0, 25)) < held  # slower than the target
    assert reward({**_params(x, y, v, i, 33.0, 25), "is_offtrack": True}) < 0.01


def test_a_slower_lap_on_the_line_earns_no_more_than_the_line_s_own(recipe: Any) -> None:
    namespace = _module(recipe)
    line, reward, line_steps = (
        namespace["RACING_LINE"],
        namespace["reward_function"],
        namespace["LINE_LAP_STEPS"],
    )

    def lap_total(steps: int) -> float:
        total = 0.0
        for k in range(1, steps + 1):
            i = min(len(line) - 1, k * len(line) // steps)
            x, y, command = line[i]
            total += reward(_params(x, y, namespace["SPEED_SHARE"] * command, i, 100.0 * k / steps, k))
        return total

    own, slower = lap_total(line_steps), lap_total(int(line_steps * 1.5))
    assert slower <= own * 1.01, (own, slower)


def test_both_kinds_take_their_action_space_from_the_line(recipe: Any) -> None:
    directed = find_directed("reInvent2019_wide_cw")
    track = load_entry(directed.entry)
    assert recipe.kind == CONTINUOUS  # what race-pace builds, by measurement (docs/RACING.md)
    grid = build_recipe(DISCRETE, track, "reInvent2019_wide_cw", "6", "m").vehicle
    assert len(grid.actions) == 15 and max(a.speed for a in grid.actions) == 4.0
    box = recipe.vehicle
    steering = [a.steering_angle for a in grid.actions]
    assert (
        box.continuous and box.steering_range[0] <= min(steering) and max(steering) <= box.steering_range[1]
    )
    assert box.speed_range[1] == 4.0
