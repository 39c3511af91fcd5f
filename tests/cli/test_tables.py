"""List tables fit the terminal (80 columns, or none at all): columns chosen by priority, names
never cut, ``--wide`` shows every column."""

from __future__ import annotations

import io
import os
import subprocess
import sys
from pathlib import Path

import pytest
from rich.console import Console

from drx.cli.tables import Column, choose_columns, fitted_table, short_paths
from drx.queue import lifecycle

from .helpers import invoke, ok

LONG = "a-model-with-a-rather-long-descriptive-name-2026"


def _render(table: object, width: int) -> list[str]:
    out = io.StringIO()
    Console(file=out, width=width, color_system=None).print(table)
    return out.getvalue().splitlines()


def test_columns_go_least_important_first_and_the_caption_names_them() -> None:
    columns = [Column("id", 0, "right"), Column("model", 0, kind="name"), Column("status", 1),
               Column("created", 3), Column("car", 2, kind="name")]  # fmt: skip
    rows = [["1", LONG, "succeeded", "2026-11-22 17:49", "my-car"]]
    kept, hidden = choose_columns(columns, rows, 80)
    assert [columns[i].header for i in kept] == ["id", "model", "status", "car"] and hidden == ["created"]
    kept, hidden = choose_columns(columns, rows, 40)  # priority-0 columns stay, even too wide
    assert [columns[i].header for i in kept] == ["id", "model"]
    lines = _render(fitted_table(columns, rows, console=Console(width=80)), 80)
    assert max(len(line) for line in lines) <= 80
    assert any(LONG in line for line in lines), "the name must be whole on one line"
    assert "hidden: created (--wide shows every column)" in " ".join(lines)
    wide = _render(fitted_table(columns, rows, console=Console(width=80), wide=True), 200)
    assert "created" in wide[1] and "hidden" not in " ".join(wide)


def test_short_paths_keeps_the_file_name() -> None:
    text = "/home/u/.drx/artifacts/models/m/reward_function.py, line 2: reward_function raised KeyError"
    assert short_paths(text) == "reward_function.py, line 2: reward_function raised KeyError"
    assert short_paths("max_minutes") == "max_minutes"


@pytest.fixture
def eighty_columns(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("COLUMNS", "80")


def _lines(*args: str) -> list[str]:
    return ok(*args).stdout.splitlines()


def test_model_list_fits_80_columns_with_whole_names(eighty_columns: None) -> None:
    ok("garage", "add", "a_car_with_a_long_name")
    ok("model", "create", LONG, "--car", "a_car_with_a_long_name")
    ok("model", "clone", LONG, LONG + "-clone")
    lines = _lines("model", "list")
    assert max(len(line) for line in lines) <= 80, "\n".join(lines)
    assert sum(LONG in line for line in lines) == 2, "\n".join(lines)
    assert "--wide" in lines[-1] or "--wide" in lines[-2]
    wide = _lines("model", "list", "--wide")
    header = next(line for line in wide if "name" in line)
    assert all(word in header for word in ("status", "track", "car", "parent", "algo", "created"))
    ok("model", "rm", LONG, "--force")
    ok("model", "rm", LONG + "-clone")
    assert "No models yet" in ok("model", "list").stdout


def test_jobs_list_shows_a_failed_jobs_error_readably(eighty_columns: None) -> None:
    ok("model", "create", "m1")
    job = lifecycle.enqueue_training("m1", {})
    assert lifecycle.claim(job.id, "test-worker")
    error = (
        "/home/someone/.drx/artifacts/models/m1/reward_function.py, line 2: reward_function raised "
        "KeyError: 'distance_from_centre'; did you mean 'distance_from_center'?\nparams: {...}"
    )
    lifecycle.finish(job.id, "test-worker", "failed", error=error)
    out = ok("jobs", "list").stdout
    assert max(len(line) for line in out.splitlines()) <= 80, out
    words = " ".join(cell.strip() for line in out.splitlines() for cell in line.split("│")[4:5])
    assert "reward_function.py, line 2: reward_function raised KeyError:" in words, out
    assert "/home/someone" not in out and "drx jobs show ID" in out


def test_list_commands_fit_without_a_terminal(tmp_path: Path) -> None:
    """The console script with its output piped, as `drx model list > file` runs: 80 columns."""
    env = {**os.environ, "DRX_HOME": str(tmp_path / "home")}
    env.pop("COLUMNS", None)
    env.pop("DRX_DATABASE_URL", None)
    drx = [sys.executable, "-m", "drx.cli.main"]
    subprocess.run([*drx, "model", "create", LONG], env=env, check=True, capture_output=True, timeout=120)
    out = subprocess.run(
        [*drx, "model", "list"], env=env, check=True, capture_output=True, text=True, timeout=120
    ).stdout
    assert max(len(line) for line in out.splitlines()) <= 80, out
    assert LONG in out


def test_wide_is_offered_on_every_list_table() -> None:
    for command in (("model", "list"), ("jobs", "list"), ("eval", "list"), ("leaderboard",)):
        result = invoke(*command, "--help")
        assert "--wide" in result.stdout, command


def test_empty_lists_say_what_to_do() -> None:
    assert "No models yet" in ok("model", "list").stdout
    assert "No jobs yet" in ok("jobs", "list").stdout
    assert "No evaluations yet" in ok("eval", "list").stdout
    assert "No reward functions stored yet" in ok("reward", "list").stdout
    assert "No time-trial evaluations yet" in ok("leaderboard").stdout
    assert "No time-trial evaluations on oval yet" in ok("leaderboard", "--track", "oval").stdout


def test_a_name_wider_than_the_terminal_folds_whole() -> None:
    name = "m" * 30 + "-" + "x" * 33  # 64 characters, the longest name allowed
    columns = [Column("id", 0, "right"), Column("model", 0, kind="name"), Column("status", 0)]
    lines = _render(fitted_table(columns, [["1", name, "succeeded"]], console=Console(width=60)), 60)
    assert max(len(line) for line in lines) <= 60
    pieces = [line.split("│")[2].strip() for line in lines if line.startswith("│")]
    assert "".join(pieces) == name and "succeeded" in " ".join(lines)
