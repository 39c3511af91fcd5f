"""``drx info``, help texts, and ``--json`` on every list/show command."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest
import typer

from drx.cli.main import app
from drx.registry.migrate import head_revision
from drx.registry.testing import external_test_url

from .helpers import invoke, ok, ok_json

COMMANDS = [
    ("info",),
    ("garage", "add"),
    ("garage", "list"),
    ("garage", "show"),
    ("garage", "rm"),
    ("track", "list"),
    ("track", "show"),
    ("track", "import"),
    ("track", "rm"),
    ("reward", "validate"),
    ("reward", "list"),
    ("reward", "show"),
    ("model", "create"),
    ("model", "clone"),
    ("model", "list"),
    ("model", "show"),
    ("model", "lineage"),
    ("model", "rm"),
]


def test_info_on_a_fresh_home_shows_the_migrated_revision(_drx_home) -> None:
    data = ok_json("info")
    assert data["schema_revision"] == head_revision() == data["schema_head"]
    assert data["data_home"] == str(_drx_home)
    assert data["artifacts"] == str(_drx_home / "artifacts")
    assert data["counts"]["models"] == 0
    if external_test_url() is None:
        assert data["database_url"] == f"sqlite:///{_drx_home / 'drx.db'}"
        assert (_drx_home / "drx.db").is_file()
    text = ok("info").stdout
    assert head_revision() in text and "schema revision" in text


def test_info_hides_database_passwords(monkeypatch, tmp_path) -> None:
    import drx.registry as registry
    from drx.services import info

    monkeypatch.setattr(info, "database_url", lambda: "postgresql://drx:secret@db.example/drx")
    monkeypatch.setattr(registry, "get_engine", lambda url: None)  # info imports them when it runs
    monkeypatch.setattr(registry, "session_scope", _fake_scope)
    from drx.registry import migrate

    monkeypatch.setattr(migrate, "current_revision", lambda engine: "0001")
    assert "secret" not in info.info()["database_url"]


class _FakeSession:
    def scalar(self, _stmt):
        return 0


def _fake_scope(url=None):
    import contextlib

    return contextlib.nullcontext(_FakeSession())


@pytest.mark.parametrize("command", COMMANDS, ids=" ".join)
def test_every_command_has_help_with_an_example(command: tuple[str, ...]) -> None:
    result = invoke(*command, "--help")
    assert result.exit_code == 0, result.output
    assert "Example" in result.stdout, f"drx {' '.join(command)} --help shows no example"


def test_top_level_help_lists_the_groups() -> None:
    out = ok("--help").stdout
    for group in ("info", "garage", "track", "reward", "model"):
        assert group in out


def test_console_script_exits_2_with_one_sentence(tmp_path) -> None:
    import os
    import subprocess
    import sys

    env = {**os.environ, "DRX_HOME": str(tmp_path / "home")}
    env.pop("DRX_DATABASE_URL", None)
    code = "from drx.cli.main import run; run()"
    proc = subprocess.run(
        [sys.executable, "-c", code, "garage", "show", "nope"], env=env, capture_output=True, text=True
    )
    assert proc.returncode == 2 and proc.stdout == ""
    assert proc.stderr.startswith("Error: Car 'nope' is not in the garage") and "Traceback" not in proc.stderr


def test_importing_the_cli_loads_no_heavy_library() -> None:
    """`drx --help` and every quick command pay only for what they use: torch, SB3, pandas,
    matplotlib and OpenCV load inside the commands that need them, SQLAlchemy with the command
    modules (tests/cli/test_startup.py follows the commands themselves)."""
    import subprocess
    import sys

    heavy = (
        "torch", "stable_baselines3", "pandas", "matplotlib", "cv2", "gymnasium", "alembic", "numpy",
        "pydantic", "sqlalchemy",
    )  # fmt: skip
    code = f"import sys, drx.cli.main; print([m for m in {heavy!r} if m in sys.modules])"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]", out


@pytest.mark.parametrize("first", ["drx", "gymnasium"])
def test_import_drx_registers_the_env_whichever_comes_first(first: str) -> None:
    """`import drx` registers drx/DeepRacer-v0 with Gymnasium without importing it: when Gymnasium is
    imported later the env is registered then (drx/__init__.py's import hook)."""
    import subprocess
    import sys

    second = "gymnasium" if first == "drx" else "drx"
    code = (
        f"import sys, {first}; print('gymnasium' in sys.modules); import {second}; import gymnasium as gym; "
        "print(type(gym.make('drx/DeepRacer-v0', track='oval').unwrapped).__name__)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == [str(first == "gymnasium"), "DeepRacerEnv"], out


def _subcommands(command: Any) -> Iterator[tuple[str, Any]]:
    """The subcommands of a Click group (loading the lazily loaded ones), or none."""
    if not isinstance(command, typer.core.TyperGroup):
        return
    ctx = typer.Context(command)
    for name in command.list_commands(ctx):
        yield name, command.get_command(ctx, name)


def _commands(command: Any, path: tuple[str, ...] = ("drx",)) -> Iterator[tuple[str, Any]]:
    """Every command below ``command`` (a Click group), with its full name."""
    for name, sub in _subcommands(command):
        yield from _commands(sub, (*path, name))
    if not isinstance(command, typer.core.TyperGroup):
        yield " ".join(path), command


def test_every_option_of_every_command_has_a_description() -> None:
    """Walks the whole command tree, so a new option without help fails here."""
    root = typer.main.get_command(app)
    bare = [
        f"{name} {param.opts[0]}"
        for name, command in _commands(root)
        for param in command.params
        if param.param_type_name == "option" and not param.hidden and not (param.help or "").strip()
    ]
    assert len(list(_commands(root))) > 30
    assert bare == [], f"options without help: {', '.join(bare)}"


def test_top_level_commands_are_listed_in_workflow_order() -> None:
    workflow = ["garage", "track", "reward", "model", "train", "evaluate", "leaderboard"]
    names = typer.main.get_command(app).list_commands(None)  # type: ignore[attr-defined]
    assert names[: len(workflow)] == workflow
    assert set(names) >= {"info", "jobs", "eval", "plot", "analyze", "sim", "worker"}
    out = ok("--help").stdout
    positions = [out.index(f" {name} ") for name in workflow]
    assert positions == sorted(positions), out


def _paths(command: Any, path: tuple[str, ...] = ()) -> Iterator[tuple[str, ...]]:
    yield path
    for name, sub in _subcommands(command):
        yield from _paths(sub, (*path, name))


def test_help_at_80_columns_never_cuts_an_option_name(monkeypatch: pytest.MonkeyPatch) -> None:
    """Rich's boxed help cut names such as --collision-penalty at 80 columns; there the plain
    layout wraps the descriptions instead."""
    monkeypatch.setenv("COLUMNS", "80")
    root = typer.main.get_command(app)
    for path in _paths(root):
        out = invoke(*path, "--help").stdout
        assert "…" not in out, f"drx {' '.join(path)} --help cuts a name:\n{out}"
        assert max(len(line) for line in out.splitlines()) <= 80, out
    assert "--collision-penalty <float>" in invoke("evaluate", "--help").stdout
    top = invoke("--help").stdout
    assert "(DeepRacer's" in top and "garage)." in top and "network..." not in top  # summaries whole
    monkeypatch.setenv("COLUMNS", "120")
    assert "╭─ Options" in invoke("evaluate", "--help").stdout  # wide terminals keep Rich's panels
