"""Domain errors name fields; the CLI says its flags for them, from one table (drx/cli/flags.py)."""

from __future__ import annotations

from typing import Any

import pytest
import typer

from drx.cli.flags import FLAGS, cli_sentence
from drx.cli.main import app
from drx.cli.model_options import HYPERPARAMETERS, PARAMETERS
from drx.config import project_root
from drx.errors import DrxError, SettingError
from drx.settings.stop import STOP_KEYS
from drx.sweep.param_specs import PARAM_FIELDS

from .helpers import fails_unchanged, ok


def _options(command: Any) -> set[str]:
    """Every option flag of ``command`` and its subcommands (Typer's own click classes, duck-typed)."""
    found = {d for p in command.params if p.param_type_name == "option" for d in p.opts + p.secondary_opts}
    if hasattr(command, "list_commands"):
        ctx = type(command).context_class(command)
        for name in command.list_commands(ctx):
            sub = command.get_command(ctx, name)
            if sub is not None:
                found |= _options(sub)
    return found


def test_every_flag_in_the_table_is_an_option_of_a_command() -> None:
    options = _options(typer.main.get_command(app))
    assert sorted(set(FLAGS.values()) - options) == []


def test_model_options_use_the_table() -> None:
    root = typer.main.get_command(app)
    model = root.get_command(type(root).context_class(root), "model")
    for command in ("create", "clone"):
        cmd = model.get_command(type(model).context_class(model), command)
        opts = {p.name: p.opts for p in cmd.params}
        assert {p.name for p in PARAMETERS} <= set(opts)
        for field in (*HYPERPARAMETERS, *STOP_KEYS, "rollout_workers"):
            assert opts[field] == [FLAGS[field]], (command, field)
    train = root.get_command(type(root).context_class(root), "train")
    opts = {p.name: p.opts for p in train.params}
    assert all(opts[field] == [FLAGS[field]] for field in STOP_KEYS)  # drx train's stop options: the same
    # a sweep's --param names are the same words as the options
    assert {f: "--" + name for name, f in PARAM_FIELDS.items()} == {f: FLAGS[f] for f in HYPERPARAMETERS}


def test_a_setting_error_is_worded_with_flags_by_the_cli() -> None:
    exc = SettingError(
        "{field} sac needs a continuous car, and {car!r} is {kind}; use {field} ppo or {continuous}.",
        "algorithm",
        "continuous",
        car="{odd}",
        kind="discrete",
    )
    assert (
        str(exc)
        == "algorithm sac needs a continuous car, and '{odd}' is discrete; use algorithm ppo or continuous."
    )
    assert cli_sentence(exc) == (
        "--algo sac needs a continuous car, and '{odd}' is discrete; use --algo ppo or --continuous."
    )
    assert exc.field == "algorithm"
    assert cli_sentence(DrxError("No model named 'x'.")) == "No model named 'x'."
    assert cli_sentence(SettingError("{field} is odd.", "not_a_flag")) == "not_a_flag is odd."


@pytest.mark.parametrize(
    ("args", "sentence"),
    [
        (("model", "create", "m", "--epochs", "11"), "--epochs 11 is out of range; use 3 to 10."),
        (("model", "create", "m", "--algo", "sac"), "--algo sac needs a continuous car"),
        (("model", "create", "m", "--max-steps", "0"), "--max-steps 0 is out of range"),
        (("model", "create", "m", "--race-type", "drag"), "--race-type drag is unknown"),
        (
            ("model", "create", "m", "--bots", "2"),
            "Bots (--bots, --bot-speed, --bot-lane-change) need --race-type",
        ),
        (
            ("garage", "add", "c", "--continuous", "--steering-levels", "5"),
            "--continuous cannot be combined with --steering-levels",
        ),
        (("garage", "add", "c", "--min-speed", "1"), "--min-speed applies only to --continuous cars."),
    ],  # fmt: skip
)
def test_cli_errors_name_the_flag(args: tuple[str, ...], sentence: str) -> None:
    err = fails_unchanged(*args, contains=sentence)
    assert "_" not in err.split(" ")[1], err  # a flag, not a field name


def test_clone_takes_the_shared_options() -> None:
    ok("model", "create", "p", "--lr", "0.0002", "--max-minutes", "5")
    fails_unchanged(
        "model", "clone", "p", "q", "--sac-alpha", "0.3", contains="--sac-alpha does not apply to PPO"
    )


def test_a_taken_track_name_names_the_flag() -> None:
    route = project_root() / "drx" / "tracks" / "drx" / "oval.npy"
    err = fails_unchanged(
        "track", "import", route, "--name", "oval", contains="import this file under another --name."
    )
    assert err.count("Error:") == 1
    ok("track", "import", route, "--name", "my-oval")
    fails_unchanged(
        "track", "import", route, "--name", "my-oval", contains="already exists; choose another --name."
    )
