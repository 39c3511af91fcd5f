"""Running ``drx`` in-process for the evaluation tests, and checking that a failure wrote nothing."""

from __future__ import annotations

import json
from typing import Any

from sqlalchemy import select
from typer.testing import CliRunner, Result

from drx.cli.main import app
from drx.config import data_home
from drx.registry import Base, session_scope

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


def snapshot() -> dict[str, Any]:
    """Every registry row and every file under the data home."""
    with session_scope() as session:
        rows = {
            t.name: [tuple(r) for r in session.execute(select(t)).all()] for t in Base.metadata.sorted_tables
        }
    home = data_home()
    files = sorted(
        str(p.relative_to(home)) for p in home.rglob("*") if p.is_file() and "drx.db" not in p.name
    )
    return {"rows": rows, "files": files}


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
