"""The CLI starts at once: commands load lazily, quick commands import no heavy library, and the
listing ``drx --help`` shows is each command's own help (issue 16, item 9)."""

from __future__ import annotations

import inspect
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import typer

from drx.cli.main import COMMANDS, app

ROOT = Path(__file__).resolve().parents[2]

# What no quick command may import: they cost from 0.1 s (NumPy, Pydantic) to seconds (torch);
# SQLAlchemy (0.2 s with the tables) neither, on a current registry (drx.registry.quick).
HEAVY = (
    "torch", "stable_baselines3", "pandas", "matplotlib", "cv2", "gymnasium", "numpy", "pydantic",
    "alembic", "optuna", "onnx", "highway_env", "sqlalchemy",
)  # fmt: skip

# Runs the console script's entry point in-process and prints, at exit, which of HEAVY and which
# drx.cli modules were imported, and whether the garbage collector ran again.
_PROBE = """
import atexit, gc, json, sys
heavy = {heavy!r}
def report():
    loaded = [m for m in heavy if m in sys.modules]
    cli = sorted(m for m in sys.modules if m.startswith("drx.cli."))
    print("PROBE " + json.dumps({{"heavy": loaded, "cli": cli, "gc": gc.isenabled()}}), file=sys.stderr)
atexit.register(report)
sys.argv = ["drx", *{argv!r}]
from drx.cli.main import run
run()
"""


def probe(argv: list[str], home: Path, heavy: tuple[str, ...] = HEAVY) -> dict:
    """What running ``drx ARGV`` (a fresh process, data home ``home``) imported."""
    env = {**os.environ, "DRX_HOME": str(home), "PYTHONPATH": str(ROOT), "COLUMNS": "80"}
    env.pop("DRX_DATABASE_URL", None)
    code = _PROBE.format(heavy=heavy, argv=argv)
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    line = next(x for x in done.stderr.splitlines() if x.startswith("PROBE "))
    return json.loads(line.removeprefix("PROBE "))


def test_help_imports_no_command_module(tmp_path: Path) -> None:
    seen = probe(["--help"], tmp_path)
    assert seen["heavy"] == []
    # the error boundary's field->flag table (drx.cli.flags) is the only other CLI module it needs
    assert seen["cli"] == ["drx.cli.app", "drx.cli.flags", "drx.cli.main", "drx.cli.output"]


@pytest.fixture(scope="module")
def ready_home(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A data home whose registry exists and whose built-in tracks' facts are cached (the first
    `drx track list` measures the 129 routes: tens of seconds on 2 busy cores, so once a module)."""
    home = tmp_path_factory.mktemp("ready-home")
    probe(["info"], home)  # creates and migrates the registry (Alembic runs then)
    probe(["track", "list"], home)  # caches the built-in tracks' facts (NumPy runs then)
    return home


@pytest.mark.parametrize("argv", [["info"], ["model", "list"], ["track", "list"], ["garage", "list"]])
def test_quick_commands_import_no_heavy_library(argv: list[str], ready_home: Path) -> None:
    """Each loads its own command module (and reads the registry), not SQLAlchemy, NumPy, Pydantic,
    Alembic or torch; the garbage collector is running again once the command's modules are in."""
    seen = probe(argv, ready_home)
    assert seen["heavy"] == [], argv
    assert seen["gc"] is True
    loaded = {m.removeprefix("drx.cli.") for m in seen["cli"]} - {"app", "main", "output", "tables"}
    assert argv[0] in loaded and "train" not in loaded and "jobs" not in loaded


# What no command's own help may import: the libraries a command loads only when it runs.
RUN_ONLY = ("torch", "stable_baselines3", "pandas", "matplotlib", "cv2")


def test_every_command_s_help_leaves_the_heavy_libraries_out(tmp_path: Path) -> None:
    """Lazy loading covers every command, not only the quick ones: a command module that imports
    torch (or SB3, pandas, matplotlib, OpenCV) at the top would make its help, and its listing
    subcommands, pay for it."""
    from drx.cli.main import COMMANDS

    loaded = {name: probe([name, "--help"], tmp_path, RUN_ONLY)["heavy"] for name in COMMANDS}
    assert {name: heavy for name, heavy in loaded.items() if heavy} == {}


def _first_paragraph(text: str | None) -> str:
    return " ".join(inspect.cleandoc(text or "").split("\n\n")[0].split())


def test_the_listing_is_each_commands_own_help() -> None:
    """COMMANDS' one-line helps (what `drx --help` shows without importing the commands) match the
    first paragraph of each command's own help, so they cannot drift apart."""
    root = typer.main.get_command(app)
    ctx = typer.Context(root)
    for name, lazy in COMMANDS.items():
        command = root.get_command(ctx, name)  # type: ignore[attr-defined]
        assert _first_paragraph(command.help) == lazy.help, name


def test_help_lists_every_command_with_its_line() -> None:
    from .helpers import ok

    out = " ".join(ok("--help").stdout.split())
    for name, lazy in COMMANDS.items():
        assert f"{name} {' '.join(lazy.help.split()[:4])}" in out, name


def test_an_unknown_command_is_refused_without_loading_the_others(tmp_path: Path) -> None:
    env = {**os.environ, "DRX_HOME": str(tmp_path), "PYTHONPATH": str(ROOT)}
    done = subprocess.run(
        [sys.executable, "-m", "drx.cli.main", "modle", "list"], env=env, capture_output=True, text=True
    )
    assert done.returncode == 2 and "No such command" in done.stderr and "Traceback" not in done.stderr


def test_a_command_closes_the_registry_at_exit(tmp_path: Path) -> None:
    """What held back garbage collection at start-up leaves nothing open: SQLite folds its write-ahead
    log back into the database when the last connection closes, so a read-only copy sees it all."""
    probe(["garage", "list"], tmp_path)
    assert (tmp_path / "drx.db").is_file()
    assert not (tmp_path / "drx.db-wal").exists()
