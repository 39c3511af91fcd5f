"""Running ``drx`` in-process and checking its results."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from typer.testing import CliRunner, Result

from drx.cli.main import app
from drx.registry.testing import snapshot

runner = CliRunner()


def invoke(*args: str) -> Result:
    """Run ``drx ARGS`` in-process."""
    return runner.invoke(app, [str(a) for a in args])


def ok(*args: str) -> Result:
    """Run ``drx ARGS`` and assert it succeeded."""
    result = invoke(*args)
    assert result.exit_code == 0, (
        f"drx {' '.join(args)} -> {result.exit_code}\n{result.output}\n{result.exception!r}"
    )
    return result


def ok_json(*args: str) -> Any:
    """Run ``drx ARGS --json``; assert stdout is exactly one JSON document and return it."""
    result = ok(*args, "--json")
    return json.loads(result.stdout)


def fails(*args: str, contains: str | tuple[str, ...] = ()) -> str:
    """Run ``drx ARGS``; assert exit code 2, one ``Error:`` sentence on stderr, no traceback."""
    result = invoke(*args)
    assert result.exit_code == 2, (
        f"drx {' '.join(args)} -> {result.exit_code}\n{result.output}\n{result.exception!r}"
    )
    err = result.stderr.strip()
    assert err.startswith("Error: "), err
    assert "\n" not in err, f"expected one line on stderr, got:\n{err}"
    assert "Traceback" not in result.output
    for text in (contains,) if isinstance(contains, str) else contains:
        assert text in err, f"{text!r} not in {err!r}"
    return err


def fails_unchanged(*args: str, contains: str | tuple[str, ...] = ()) -> str:
    """:func:`fails`, and the registry and data home are unchanged afterwards."""
    before = snapshot()
    err = fails(*args, contains=contains)
    assert snapshot() == before, f"drx {' '.join(args)} changed the registry"
    return err


def write(path: Path, text: str) -> Path:
    """Write a text file and return its path."""
    path.write_text(text, encoding="utf-8")
    return path
