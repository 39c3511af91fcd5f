"""Running ``drx`` in-process for the analysis tests."""

from __future__ import annotations

import json
from typing import Any

from typer.testing import CliRunner, Result

from drx.cli.main import app
from drx.registry.testing import snapshot

runner = CliRunner()


def invoke(*args: object) -> Result:
    """Run ``drx ARGS``."""
    return runner.invoke(app, [str(a) for a in args])


def ok_json(*args: object) -> Any:
    """Run ``drx ARGS --json``; assert success and return the JSON document."""
    result = invoke(*args, "--json")
    assert result.exit_code == 0, f"drx {args} -> {result.exit_code}\n{result.output}\n{result.exception!r}"
    return json.loads(result.stdout)


def fails_unchanged(*args: object, contains: str = "") -> str:
    """Run ``drx ARGS``: exit code 2, one ``Error:`` sentence, no traceback, nothing stored."""
    before = snapshot()
    result = invoke(*args)
    assert result.exit_code == 2, f"drx {args} -> {result.exit_code}\n{result.output}\n{result.exception!r}"
    err = result.stderr.strip()
    assert err.startswith("Error: ") and "\n" not in err and "Traceback" not in result.output, err
    assert contains in err, f"{contains!r} not in {err!r}"
    assert snapshot() == before, f"drx {args} changed the registry or the data home"
    return err
