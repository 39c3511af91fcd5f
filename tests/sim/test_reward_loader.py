"""Loading users' reward functions, and errors that name their file and line."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from drx.errors import DrxError
from drx.sim.reward_loader import RewardFunctionError, load_reward_function

GOOD = '''import math


def reward_function(params):
    """Reward staying near the centre."""
    half = 0.5 * params["track_width"]
    return float(math.exp(-params["distance_from_center"] / half))
'''

RAISING = """def helper(params):
    return params["no_such_key"]


def reward_function(params):
    return helper(params) + 1.0
"""


def _write(tmp_path: Path, text: str, name: str = "reward.py") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def test_loads_a_file_and_calls_it(tmp_path: Path) -> None:
    fn = load_reward_function(_write(tmp_path, GOOD))
    assert fn({"track_width": 1.0, "distance_from_center": 0.0}) == 1.0
    assert fn({"track_width": 1.0, "distance_from_center": 0.5}) == pytest.approx(math.exp(-1))
    assert fn.source_code == GOOD and fn.source_path.endswith("reward.py")
    assert fn.calls == 2 and len(fn.sha256) == 64


def test_raising_function_names_file_and_line(tmp_path: Path) -> None:
    fn = load_reward_function(_write(tmp_path, RAISING))
    params = {"x": 1.0}
    with pytest.raises(RewardFunctionError) as err:
        fn(params)
    assert isinstance(err.value, DrxError)
    assert err.value.line == 2  # inside helper, the deepest line of the user's file
    assert "reward.py, line 2" in str(err.value) and "KeyError" in str(err.value)
    assert err.value.params is params


def test_syntax_error_names_the_line(tmp_path: Path) -> None:
    path = _write(tmp_path, "def reward_function(params):\n    return (1.0\n\n")
    with pytest.raises(RewardFunctionError, match="syntax error") as err:
        load_reward_function(path)
    assert err.value.line is not None and err.value.line >= 2


def test_import_time_error_and_missing_function(tmp_path: Path) -> None:
    with pytest.raises(RewardFunctionError, match="line 2"):
        load_reward_function(_write(tmp_path, "x = 1\nimport no_such_module_drx\n", "a.py"))
    with pytest.raises(RewardFunctionError, match="no function named reward_function"):
        load_reward_function(_write(tmp_path, "def reward(params):\n    return 1.0\n", "b.py"))
    with pytest.raises(RewardFunctionError, match="does not exist"):
        load_reward_function(tmp_path / "missing.py")


@pytest.mark.parametrize("value", [math.nan, math.inf, 2e5, "high", None, True])
def test_bad_return_values_are_rejected(value: object) -> None:
    def reward_function(params: dict) -> object:
        return value

    fn = load_reward_function(reward_function)
    with pytest.raises(RewardFunctionError, match="finite number"):
        fn({})


def test_callables_and_ints_are_accepted() -> None:
    fn = load_reward_function(lambda params: 3)
    assert fn({}) == 3.0 and isinstance(fn({}), float)
    assert load_reward_function(fn) is fn
