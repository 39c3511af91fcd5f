"""Running ``drx`` in-process for the analysis tests."""

from __future__ import annotations

import json
from typing import Any

from sqlalchemy import select
from typer.testing import CliRunner, Result

from drx.cli.main import app
from drx.config import data_home
from drx.registry import Base, session_scope

runner = CliRunner()


def invoke(*args: object) -> Result:
    """Run ``drx ARGS``."""
    return runner.invoke(app, [str(a) for a in args])


def ok_json(*args: object) -> Any:
    """Run ``drx ARGS --json``; assert success and return the JSON document."""
    result = invoke(*args, "--json")
    assert result.exit_code == 0, f"drx {args} -> {result.exit_code}\n{result.output}\n{result.exception!r}"
    return json.loads(result.stdout)


def snapshot() -> dict[str, Any]:
    """Every registry row and every file of the data home (to check that a failure stored nothing)."""
    with session_scope() as session:
        rows = {
            t.name: [tuple(r) for r in session.execute(select(t)).all()] for t in Base.metadata.sorted_tables
        }
    home = data_home()
    files = sorted(
        str(p.relative_to(home)) for p in home.rglob("*") if p.is_file() and "drx.db" not in p.name
    )
    return {"rows": rows, "files": files}


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
