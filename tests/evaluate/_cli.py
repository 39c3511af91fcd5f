"""Running ``drx`` in-process for the evaluation tests, and checking that a failure wrote nothing."""

from __future__ import annotations

import json
from typing import Any

from typer.testing import CliRunner, Result

from drx.cli.main import app
from drx.registry.testing import snapshot

runner = CliRunner()


def invoke(*args: Any) -> Result:
    """``drx ARGS`` in-process."""
    return runner.invoke(app, [str(a) for a in args])


def drx(*args: Any) -> Result:
    """``drx ARGS``, which must succeed."""
    result = invoke(*args)
    assert result.exit_code == 0, f"drx {args} -> {result.exit_code}\n{result.output}\n{result.exception!r}"
    return result


def drx_json(*args: Any) -> Any:
    """``drx ARGS --json``: stdout is exactly one JSON document."""
    return json.loads(drx(*args, "--json").stdout)


def fails_unchanged(*args: Any, contains: str) -> str:
    """``drx ARGS`` exits 2 with one ``Error:`` sentence containing ``contains``, and changes nothing."""
    before = snapshot()
    result = invoke(*args)
    assert result.exit_code == 2, f"drx {args} -> {result.exit_code}\n{result.output}\n{result.exception!r}"
    err = result.stderr.strip()
    assert err.startswith("Error: ") and "\n" not in err, err
    assert "Traceback" not in result.output
    assert contains in err, f"{contains!r} not in {err!r}"
    assert snapshot() == before, f"drx {args} changed the registry or the data home"
    return err
