"""The newest migration the code knows, read from the migration files without SQLAlchemy or Alembic.

:func:`code_head` is what every start compares with the database's ``alembic_version``
(:mod:`drx.registry.migrate`, :mod:`drx.registry.quick`); Alembic decides only when the files do not
name exactly one head.
"""

from __future__ import annotations

import ast
import functools
from pathlib import Path

MIGRATIONS_DIR = Path(__file__).resolve().parent / "migrations"


@functools.cache
def code_head() -> str | None:
    """The one revision no migration file revises, read from the files' ``revision`` and
    ``down_revision`` assignments without importing them or Alembic; ``None`` when a file does not
    say both, or when there is not exactly one head (then :func:`alembic_head` decides)."""
    revisions: set[str] = set()
    revised: set[str] = set()
    for path in sorted((MIGRATIONS_DIR / "versions").glob("*.py")):
        found = _assignments(path, ("revision", "down_revision"))
        revision, down = found.get("revision"), found.get("down_revision", "")
        if not isinstance(revision, str) or down == "":
            return None
        revisions.add(revision)
        if isinstance(down, str):
            revised.add(down)
        elif isinstance(down, tuple | list):
            revised.update(str(d) for d in down)
    heads = revisions - revised
    return next(iter(heads)) if len(heads) == 1 else None


def _assignments(path: Path, names: tuple[str, ...]) -> dict[str, object]:
    """The literal values a module assigns to ``names`` at its top level."""
    found: dict[str, object] = {}
    for node in ast.parse(path.read_text(encoding="utf-8")).body:
        target, value = None, None
        if isinstance(node, ast.Assign) and len(node.targets) == 1:
            target, value = node.targets[0], node.value
        elif isinstance(node, ast.AnnAssign):
            target, value = node.target, node.value
        if isinstance(target, ast.Name) and target.id in names and value is not None:
            try:
                found[target.id] = ast.literal_eval(value)
            except ValueError:
                continue
    return found
