"""Reward functions under limits: time, exits, printed output, their own copy of ``params``."""

from __future__ import annotations

import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from drx.errors import DrxError, Interruption
from drx.sim import reward_guard
from drx.sim.env import DeepRacerEnv
from drx.sim.reward_loader import RewardFunctionError, load_reward_function

ROOT = Path(__file__).resolve().parents[2]
LIMIT = 0.2  # [s] the time limit the tests use


def _file(tmp_path: Path, body: str, name: str = "reward.py") -> Path:
    path = tmp_path / name
    path.write_text(body)
    return path


@pytest.mark.parametrize(
    "body, line",
    [
        ("def reward_function(params):\n    while True:\n        pass\n", (2, 3)),
        # a blocking sleep: ended by a signal while Python owns it, else when it returns
        ("import time\ndef reward_function(params):\n    time.sleep(3)\n    return 1.0\n", (3,)),
        (
            "def reward_function(params):\n    while True:\n        try:\n"
            "            [i for i in range(10**6)]\n        except Exception:\n            pass\n",
            (2, 3, 4),
        ),
    ],
    ids=["loop", "sleep", "except-exception"],
)
def test_a_call_over_the_time_limit_is_an_error_naming_the_line(
    tmp_path: Path, body: str, line: tuple[int, ...]
) -> None:
    reward = load_reward_function(_file(tmp_path, body), time_limit=LIMIT)
    t0 = time.monotonic()
    with pytest.raises(RewardFunctionError, match=r"ran longer than 0.2 s \(the time limit\)") as info:
        reward({"x": 1.0})
    assert time.monotonic() - t0 < 3.0 + 1.0
    assert info.value.line in line
    time.sleep(3 * reward_guard._POLL)  # the guard is disarmed afterwards: no late signal arrives


def test_the_limit_is_configurable_and_checked(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    path = _file(tmp_path, "def reward_function(params):\n    return 1.0\n")
    monkeypatch.setenv(reward_guard.ENV_TIME_LIMIT, "5")
    assert load_reward_function(path).time_limit == 5.0
    monkeypatch.setenv(reward_guard.ENV_TIME_LIMIT, "soon")
    with pytest.raises(DrxError, match="DRX_REWARD_TIME_LIMIT='soon' is not a positive number"):
        load_reward_function(path)
    monkeypatch.delenv(reward_guard.ENV_TIME_LIMIT)
    assert load_reward_function(path).time_limit == reward_guard.DEFAULT_TIME_LIMIT == 1.0


def test_a_fast_reward_is_never_interrupted_late(tmp_path: Path) -> None:
    reward = load_reward_function(
        _file(tmp_path, "def reward_function(params):\n    return 1.0\n"), time_limit=0.05
    )
    t0 = time.monotonic()
    while time.monotonic() - t0 < 0.3:  # drx's own code between calls outlives the limit: no signal
        assert reward({"x": 1.0}) == 1.0
        time.sleep(0.06)


def test_top_level_code_runs_under_a_limit(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setattr(reward_guard, "LOAD_TIME_LIMIT", LIMIT)
    path = _file(tmp_path, "while True:\n    pass\ndef reward_function(params):\n    return 1.0\n")
    with pytest.raises(RewardFunctionError, match="loading the file ran longer than 0.2 s"):
        load_reward_function(path)


@pytest.mark.parametrize(
    "body, said",
    [
        ("import os\ndef reward_function(params):\n    os._exit(0)\n", "called os._exit(0)"),
        ("from os import _exit\ndef reward_function(params):\n    _exit(3)\n", "called os._exit(3)"),
        ("import os\ndef reward_function(params):\n    os.abort()\n", "called os.abort()"),
        ("import sys\ndef reward_function(params):\n    sys.exit(4)\n", "called sys.exit(4)"),
        ("def reward_function(params):\n    exit()\n", "called sys.exit(None)"),
    ],
)
def test_exits_are_reported_as_such(tmp_path: Path, body: str, said: str) -> None:
    reward = load_reward_function(_file(tmp_path, body))
    with pytest.raises(
        RewardFunctionError, match=f"{said.replace('(', '[(]').replace(')', '[)]')}; a reward"
    ):
        reward({"x": 1.0})


def test_an_exit_at_load_is_reported(tmp_path: Path) -> None:
    path = _file(tmp_path, "import os\nos._exit(1)\n")
    with pytest.raises(RewardFunctionError, match=r"line 2: loading the file called os._exit\(1\)"):
        load_reward_function(path)


def test_the_rest_of_os_still_works(tmp_path: Path) -> None:
    body = "import os, os.path\ndef reward_function(params):\n    return float(len(os.path.join('a', 'b')))\n"
    assert load_reward_function(_file(tmp_path, body))({}) == 3.0


def test_interruptions_pass_through(tmp_path: Path) -> None:
    """A stop request or worker shutdown raised during a slow call is not the reward's error."""

    class Stop(Interruption):
        pass

    reward = load_reward_function(
        _file(tmp_path, "import time\ndef reward_function(params):\n    time.sleep(3)\n"), time_limit=60
    )
    timer = threading.Timer(0.1, lambda: reward_guard.interrupt(Stop))
    timer.start()
    t0 = time.monotonic()
    with pytest.raises(Stop):
        reward({"x": 1.0})
    assert time.monotonic() - t0 < 5.0
    assert reward_guard.interrupt(Stop) is False  # no call runs now


def test_print_goes_to_stderr_capped(tmp_path: Path, capfd: pytest.CaptureFixture[str]) -> None:
    body = "def reward_function(params):\n    print('step', params['steps'], 'x' * 1000)\n    return 1.0\n"
    reward = load_reward_function(_file(tmp_path, body))
    output = reward_guard.CappedOutput(cap=4096)
    old, reward_guard.output = reward_guard.output, output
    try:
        for step in range(50):
            reward({"steps": step})
    finally:
        reward_guard.output = old
    out, err = capfd.readouterr()
    assert out == ""  # standard output (``--json``) stays clean
    assert "step 0 " in err and "printed more than 4 KiB" in err
    assert len(err) < 4096 + 200
    assert output.lines == 50 and output.dropped > 40_000


MUTATE = """
def reward_function(params):
    params["x"] = "junk"
    params["progress"] = 99.0
    params["waypoints"].clear()
    params["closest_waypoints"][0] = -5
    params["racing_line"].append((1.0, 2.0))
    params["objects_location"].clear()
    return 1.0
"""


def test_a_reward_cannot_change_drx_params(tmp_path: Path) -> None:
    reward = load_reward_function(_file(tmp_path, MUTATE))
    line = [(0.0, 0.0), (1.0, 0.0)]
    params = {
        "x": 1.0, "progress": 3.0, "waypoints": [(0.0, 0.0), (1.0, 1.0)], "closest_waypoints": [0, 1],
        "racing_line": line, "objects_location": [[1.0, 2.0]],
    }  # fmt: skip
    for _ in range(2):
        assert reward(params) == 1.0
    assert params == {
        "x": 1.0, "progress": 3.0, "waypoints": [(0.0, 0.0), (1.0, 1.0)], "closest_waypoints": [0, 1],
        "racing_line": [(0.0, 0.0), (1.0, 0.0)], "objects_location": [[1.0, 2.0]],
    }  # fmt: skip
    assert params["racing_line"] is line


def test_training_with_a_mutating_reward_keeps_the_trace_right(tmp_path: Path) -> None:
    env = DeepRacerEnv(
        track="oval", reward_function=_file(tmp_path, MUTATE), extra_params={"racing_line": [(0.0, 0.0)]}
    )
    env.reset(seed=0)
    for _ in range(3):
        _obs, reward, _term, _trunc, info = env.step(0)
        p = info["params"]
        assert reward == 1.0 and isinstance(p["x"], float) and p["progress"] < 99.0
        assert p["waypoints"] and p["closest_waypoints"][0] >= 0
    assert env.extra_params["racing_line"] == [(0.0, 0.0)]


def test_a_reward_that_swallows_every_interruption_ends_the_process(tmp_path: Path) -> None:
    path = _file(
        tmp_path,
        "def reward_function(params):\n    while True:\n        try:\n            while True:\n"
        "                pass\n        except BaseException:\n            pass\n",
    )
    code = (
        "from drx.sim import reward_guard\nreward_guard.STUCK_GRACE = 0.5\n"
        "from drx.sim.reward_loader import load_reward_function\n"
        f"load_reward_function({str(path)!r}, time_limit=0.1)({{}})\n"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, timeout=60,
        env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"},
    )  # fmt: skip
    assert proc.returncode == 2
    assert "caught every attempt to stop it" in proc.stderr
