"""The sample reward functions in rewards/: DeepRacer-compatible, finite on every kind of state."""

from __future__ import annotations

import ast
import math
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from ._paths import REWARD_FILES, TRACK_FILES, TRACK_FILES_DIR, load_module

IDS = [p.stem for p in REWARD_FILES]
EXPECTED = {
    "follow_center_line",
    "stay_inside_borders",
    "prevent_zigzag",
    "object_avoidance",
    "head_to_bot",
    "progress_speed",
    "pursuit",
}
OVAL = np.load(TRACK_FILES_DIR / "oval.npy")
WIDTH = float(np.linalg.norm(OVAL[0, 2:4] - OVAL[0, 4:6]))
LENGTH = float(np.sum(np.linalg.norm(np.diff(OVAL[:, 0:2], axis=0), axis=1)))


def _reward(path: Path) -> Callable[[dict[str, Any]], Any]:
    return load_module(path).reward_function


def _pose(index: int, offset: float) -> tuple[float, float, float]:
    """(x, y, heading [rad]) ``offset`` m left (+) or right (-) of the oval's centre row ``index``."""
    (cx, cy), (nx, ny) = OVAL[index, 0:2], OVAL[index + 1, 0:2]
    heading = math.atan2(ny - cy, nx - cx)
    return cx - offset * math.sin(heading), cy + offset * math.cos(heading), heading


def _params(index: int = 10, offset: float = 0.0, **changes: Any) -> dict[str, Any]:
    """Hand-made params ``offset`` m left (+) or right (-) of the oval's centre row ``index``."""
    x, y, heading = _pose(index, offset)
    params: dict[str, Any] = {
        "x": x,
        "y": y,
        "heading": math.degrees(heading),
        "speed": 1.0,
        "steering_angle": 0.0,
        "progress": 100.0 * index / (len(OVAL) - 1),
        "steps": max(1, index * 2),
        "track_length": LENGTH,
        "track_width": WIDTH,
        "distance_from_center": abs(offset),
        "is_left_of_center": offset > 0,
        "all_wheels_on_track": abs(offset) < 0.5 * WIDTH - 0.09,
        "is_offtrack": abs(offset) > 0.5 * WIDTH + 0.09,
        "is_crashed": False,
        "is_reversed": False,
        "closest_waypoints": [index, index + 1],
        "waypoints": [(float(px), float(py)) for px, py in OVAL[:, 0:2]],
        "closest_objects": [0, 0],
        "objects_location": [],
        "objects_left_of_center": [],
        "objects_speed": [],
        "objects_heading": [],
        "objects_distance": [],
    }
    params.update(changes)
    return params


def _with_object(offset: float, ahead: float, left: bool, speed: float = 0.0) -> dict[str, Any]:
    """Params of a car at row 10, ``offset`` m off centre, with an object ``ahead`` m on in the left
    or right lane (a quarter width off centre) and another one 3 m behind, in the left lane."""
    index = 10
    params = _params(index, offset)
    rows_ahead = round(ahead / (LENGTH / (len(OVAL) - 1)))
    bx, by, heading = _pose(index + rows_ahead, (0.25 if left else -0.25) * WIDTH)
    rows_behind = round(3.0 / (LENGTH / (len(OVAL) - 1)))
    hx, hy, _ = _pose(index - rows_behind, 0.25 * WIDTH)
    s = params["progress"] / 100.0 * LENGTH
    params.update(
        closest_objects=[0, 1],
        objects_location=[(hx, hy), (bx, by)],
        objects_left_of_center=[True, left],
        objects_speed=[speed, speed],
        objects_heading=[heading, heading],
        objects_distance=[s - 3.0, s + ahead],
    )
    return params


CASES: dict[str, dict[str, Any]] = {
    "start": _params(0, steps=1, progress=0.0),
    "centre": _params(10),
    "near_left_border": _params(10, 0.4),
    "near_right_border": _params(10, -0.4),
    "off_track": _params(10, 0.9, speed=1.0, steering_angle=30.0),
    "hard_steering": _params(20, 0.1, steering_angle=-30.0, speed=0.5),
    "lap_complete": _params(0, progress=100.0, steps=240),
    "fast": _params(10, speed=4.0),
    "box_ahead_same_lane": _with_object(0.25, 0.4, left=True),
    "box_ahead_other_lane": _with_object(0.25, 0.4, left=False),
    "box_far_ahead": _with_object(-0.2, 3.0, left=False),
    "crashed": {**_with_object(0.25, 0.1, left=True), "is_crashed": True},
    "bot_ahead": _with_object(-0.2, 0.9, left=False, speed=1.0),
    "bot_beside": _with_object(0.25, 0.3, left=False, speed=1.0),
    "reversed": _params(10, is_reversed=True),
}


def test_every_sample_is_there() -> None:
    assert {p.stem for p in REWARD_FILES} == EXPECTED


@pytest.mark.parametrize("path", REWARD_FILES, ids=IDS)
def test_deepracer_compatible_source(path: Path) -> None:
    """One reward_function(params), a docstring, and only the math module (DeepRacer's own sandbox)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    assert ast.get_docstring(tree), "explain the idea in a module docstring"
    imports = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            imports.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            imports.add(node.module or "")
    assert imports <= {"math"}
    funcs = [n for n in tree.body if isinstance(n, ast.FunctionDef) and n.name == "reward_function"]
    assert len(funcs) == 1 and len(funcs[0].args.args) == 1


def _timed(reward: Callable[[dict[str, Any]], Any], params: dict[str, Any]) -> float:
    start = time.perf_counter()
    reward(params)
    return time.perf_counter() - start


@pytest.mark.parametrize("case", sorted(CASES))
@pytest.mark.parametrize("path", REWARD_FILES, ids=IDS)
def test_finite_float_on_every_case(path: Path, case: str) -> None:
    params = CASES[case]
    before = repr(params)
    reward = _reward(path)
    value = reward(params)
    # Best of five: one call can be descheduled on a busy 2-core machine; a slow function is slow every time.
    elapsed = min(_timed(reward, params) for _ in range(5))
    assert type(value) is float
    assert math.isfinite(value) and -1e5 <= value <= 1e5
    assert value > 0.0
    assert repr(params) == before, "a reward function must not change params"
    assert elapsed < 0.01


@pytest.mark.parametrize("path", REWARD_FILES, ids=IDS)
def test_empty_object_lists(path: Path) -> None:
    """DeepRacer passes closest_objects [0, 0] and empty lists on tracks without objects."""
    value = _reward(path)(_params(10, 0.2, closest_objects=[0, 0]))
    assert math.isfinite(value)


def _r(name: str, case: str | dict[str, Any]) -> float:
    params = CASES[case] if isinstance(case, str) else case
    return _reward(REWARD_FILES[IDS.index(name)])(params)


def test_centre_line_rewards_prefer_the_centre() -> None:
    for name in ("follow_center_line", "prevent_zigzag"):
        assert _r(name, "centre") > _r(name, "near_left_border") > _r(name, "off_track")


def test_stay_inside_borders_is_flat_on_the_road() -> None:
    assert _r("stay_inside_borders", "centre") == _r("stay_inside_borders", _params(10, 0.3))
    assert _r("stay_inside_borders", "off_track") < _r("stay_inside_borders", "centre")


def test_prevent_zigzag_penalises_hard_steering() -> None:
    calm = _params(10, steering_angle=5.0)
    hard = _params(10, steering_angle=-25.0)
    assert _r("prevent_zigzag", hard) == pytest.approx(0.8 * _r("prevent_zigzag", calm))


def test_object_avoidance_keeps_out_of_the_box_lane() -> None:
    same = _r("object_avoidance", "box_ahead_same_lane")
    other = _r("object_avoidance", "box_ahead_other_lane")
    assert other > same
    assert _r("object_avoidance", "crashed") < same
    closer = [_r("object_avoidance", _with_object(0.25, d, left=True)) for d in (1.0, 0.6, 0.4, 0.2)]
    assert closer == sorted(closer, reverse=True) and closer[0] > closer[-1]


def test_head_to_bot_keeps_a_gap_and_overtakes() -> None:
    following = [_r("head_to_bot", _with_object(0.25, d, left=True, speed=1.0)) for d in (2.0, 1.0, 0.5)]
    assert following == sorted(following, reverse=True) and following[0] > following[-1]
    assert _r("head_to_bot", "bot_beside") > _r("head_to_bot", _with_object(0.25, 0.3, left=True))
    assert _r("head_to_bot", "crashed") < _r("head_to_bot", "bot_ahead")


def test_progress_speed_rewards_pace_speed_and_a_fast_lap() -> None:
    assert _r("progress_speed", "fast") > _r("progress_speed", "centre")
    slow_pace = _params(10, steps=200)
    assert _r("progress_speed", "centre") > _r("progress_speed", slow_pace)
    quick_lap = _params(0, progress=100.0, steps=200)
    slow_lap = _params(0, progress=100.0, steps=600)
    assert _r("progress_speed", quick_lap) > _r("progress_speed", slow_lap) > _r("progress_speed", "centre")


def test_pursuit_pays_pace_and_speed_squared_on_the_road_only() -> None:
    assert _r("pursuit", "fast") > _r("pursuit", "centre")
    assert _r("pursuit", "centre") > _r("pursuit", _params(10, steps=200))
    assert _r("pursuit", "off_track") == 0.01


@pytest.mark.parametrize("track_path", TRACK_FILES, ids=[p.stem for p in TRACK_FILES])
def test_on_drx_validate_cases(track_path: Path) -> None:
    """The same sample states ``drx reward validate`` uses, on each of drx's own tracks."""
    params_mod = pytest.importorskip("drx.sim.params")
    track_mod = pytest.importorskip("drx.sim.track")
    track, _ = track_mod.Track.from_route(np.load(track_path), name=track_path.stem)
    for case, params in params_mod.sample_params_cases(track).items():
        for path in REWARD_FILES:
            value = _reward(path)(params)
            assert isinstance(value, float) and math.isfinite(value), f"{path.name} on {case}"
