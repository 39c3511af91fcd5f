"""``drx reward validate``: the console's Validate button."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from drx.config import project_root

from .helpers import fails, invoke, ok, ok_json, write

SAMPLES = sorted((project_root() / "rewards").glob("*.py"))


@pytest.mark.parametrize("sample", SAMPLES, ids=lambda p: p.stem)
def test_every_sample_reward_validates(sample: Path) -> None:
    report = ok_json("reward", "validate", str(sample))
    assert report["ok"] and len(report["cases"]) == 5
    assert {c["case"] for c in report["cases"]} == {
        "start", "mid_lap_left", "mid_lap_right", "off_track", "lap_complete"
    }  # fmt: skip


def test_sample_by_name_on_another_track() -> None:
    out = ok("reward", "validate", "follow_center_line", "--track", "kidney-cw").stdout
    assert "Valid" in out and "kidney-cw" in out


def test_exception_reports_the_users_line(tmp_path: Path) -> None:
    path = write(tmp_path / "r.py", "def reward_function(params):\n    if params['is_offtrack']:\n"
                 "        return 1 / 0\n    return 1.0\n")  # fmt: skip
    err = fails(
        "reward", "validate", str(path), contains=("1 of 5", "off_track", "line 3", "ZeroDivisionError")
    )
    assert "r.py" in err
    result = invoke("reward", "validate", str(path), "--json")
    assert result.exit_code == 2
    report = json.loads(result.stdout)
    bad = [c for c in report["cases"] if not c["ok"]]
    assert report["ok"] is False and [c["case"] for c in bad] == ["off_track"] and bad[0]["line"] == 3


@pytest.mark.parametrize(
    ("body", "words"),
    [
        ("    return float('nan')\n", ("nan", "finite")),
        ("    return float('inf')\n", ("inf",)),
        ("    return 'high'\n", ("'high'",)),
        ("    return None\n", ("None",)),
        ("    return 2e5\n", ("200000",)),
        ("    return -1e6\n", ("-1000000",)),
    ],
)
def test_bad_values_fail(tmp_path: Path, body: str, words: tuple[str, ...]) -> None:
    path = write(tmp_path / "r.py", "def reward_function(params):\n" + body)
    fails("reward", "validate", str(path), contains=("5 of 5", *words))


def test_files_that_cannot_load(tmp_path: Path) -> None:
    syntax = write(tmp_path / "syntax.py", "def reward_function(params):\n    x = (\n    return 1.0\n")
    fails("reward", "validate", str(syntax), contains=("syntax error", "line 2"))
    missing = write(tmp_path / "nofunc.py", "def reward(params):\n    return 1.0\n")
    fails("reward", "validate", str(missing), contains="reward_function")
    boom = write(tmp_path / "boom.py", "import not_a_module_drx\n")
    fails("reward", "validate", str(boom), contains=("line 1", "not_a_module_drx"))
    fails("reward", "validate", str(tmp_path / "absent.py"), contains=("absent.py", "follow_center_line"))
    fails("reward", "validate", "follow_center_line", "--track", "atlantis", contains="atlantis")


def test_slow_reward_warns(tmp_path: Path) -> None:
    path = write(tmp_path / "slow.py", "import time\ndef reward_function(params):\n    time.sleep(0.0015)\n"
                 "    return 1.0\n")  # fmt: skip
    result = ok("reward", "validate", str(path))
    assert "over 1 ms" in result.stdout
    report = ok_json("reward", "validate", str(path))
    assert all(c["warning"] for c in report["cases"])


def test_list_and_show_stored_rewards(tmp_path: Path) -> None:
    assert ok_json("reward", "list") == []
    path = write(tmp_path / "mine.py", "def reward_function(params):\n    return 0.5\n")
    ok("model", "create", "m1", "--reward", str(path))
    ok("model", "create", "m2", "--reward", str(path))
    stored = ok_json("reward", "list")
    assert len(stored) == 1 and stored[0]["models"] == ["m1", "m2"] and stored[0]["filename"] == "mine.py"
    assert "mine.py" in ok("reward", "list").stdout
    path.write_text("def reward_function(params):\n    return 0.7\n")  # the model keeps its code
    shown = ok_json("reward", "show", "m1")
    assert "return 0.5" in shown["code"] and shown["sha256"] == stored[0]["sha256"]
    assert ok_json("reward", "show", stored[0]["sha256"][:8])["models"] == ["m1", "m2"]
    assert "return 0.5" in ok("reward", "show", "m2").stdout
    fails("reward", "show", "ghost", contains="ghost")
    fails("reward", "show", "abcdef0", contains="abcdef0")
