"""The import graph keeps drx's layers (docs/CONTRACTS.md, Layers): the import-linter contracts in
pyproject.toml hold, and no two top-level packages of drx import each other, even through imports
inside functions."""

from __future__ import annotations

import fnmatch
import os
import shutil
import subprocess
import sys
import tomllib
from collections.abc import Iterable, Mapping
from pathlib import Path

import grimp
import pytest

ROOT = Path(__file__).resolve().parents[1]


def _lint_imports(root: Path = ROOT) -> subprocess.CompletedProcess[str]:
    """``lint-imports`` over the ``drx`` package under ``root``, with ``root/pyproject.toml``."""
    script = Path(sys.executable).with_name("lint-imports")
    if not script.is_file():
        pytest.skip(f"import-linter is not installed beside {sys.executable} (pip install -e '.[dev]')")
    env = {**os.environ, "PYTHONPATH": str(root)}
    return subprocess.run(
        [str(script), "--no-cache", "--no-logo", "--config", str(root / "pyproject.toml")],
        cwd=root, env=env, capture_output=True, text=True, timeout=300,
    )  # fmt: skip


def test_import_linter_contracts_are_kept() -> None:
    """The layers contract (each layer imports only those below it) and the acyclic-siblings
    contract (no cycle between the modules of any package) of pyproject.toml."""
    done = _lint_imports()
    assert done.returncode == 0, done.stdout + done.stderr
    assert "2 kept, 0 broken" in done.stdout, done.stdout


def test_a_back_edge_inside_a_function_breaks_the_contract(tmp_path: Path) -> None:
    """A copy of drx whose simulator imports the CLI inside a function fails the check."""
    shutil.copytree(ROOT / "drx", tmp_path / "drx", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(ROOT / "pyproject.toml", tmp_path / "pyproject.toml")
    with (tmp_path / "drx" / "sim" / "track.py").open("a", encoding="utf-8") as f:
        f.write("\n\ndef _back_edge() -> None:\n    from drx.cli import main  # noqa: F401\n")
    done = _lint_imports(tmp_path)
    assert done.returncode != 0, done.stdout
    assert "drx.sim.track -> drx.cli.main" in done.stdout, done.stdout


def known_exceptions() -> list[tuple[str, str]]:
    """The ``ignore_imports`` of pyproject's acyclic contract, as (importer, imported) patterns."""
    config = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    contracts = config["tool"]["importlinter"]["contracts"]
    acyclic = next(c for c in contracts if c["type"] == "acyclic_siblings")
    pairs = [line.split("->") for line in acyclic.get("ignore_imports", [])]
    return [(a.strip(), b.strip()) for a, b in pairs]


def package_edges(graph: grimp.ImportGraph, ignore: Iterable[tuple[str, str]] = ()) -> dict[str, set[str]]:
    """Which top-level drx packages (and modules) each one imports, its own submodules aside."""
    ignore = list(ignore)
    edges: dict[str, set[str]] = {}
    for module in graph.modules:
        parts = module.split(".")
        if len(parts) < 2:
            continue
        for imported in graph.find_modules_directly_imported_by(module):
            if not imported.startswith("drx.") or imported.split(".")[1] == parts[1]:
                continue
            if any(fnmatch.fnmatchcase(module, a) and fnmatch.fnmatchcase(imported, b) for a, b in ignore):
                continue
            edges.setdefault(parts[1], set()).add(imported.split(".")[1])
    return edges


def cycles(edges: Mapping[str, set[str]]) -> list[list[str]]:
    """The strongly connected groups of more than one node (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    found: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        for nxt in edges.get(node, ()):
            if nxt not in index:
                visit(nxt)
                low[node] = min(low[node], low[nxt])
            elif nxt in stack:
                low[node] = min(low[node], index[nxt])
        if low[node] == index[node]:
            group = []
            while True:
                member = stack.pop()
                group.append(member)
                if member == node:
                    break
            if len(group) > 1:
                found.append(sorted(group))

    for node in sorted(set(edges) | {n for targets in edges.values() for n in targets}):
        if node not in index:
            visit(node)
    return found


@pytest.fixture(scope="module")
def graph() -> grimp.ImportGraph:
    sys.path.insert(0, str(ROOT))  # this checkout's drx, whatever is installed
    try:
        return grimp.build_graph("drx", cache_dir=None)
    finally:
        sys.path.remove(str(ROOT))


def test_no_two_drx_packages_import_each_other(graph: grimp.ImportGraph) -> None:
    edges = package_edges(graph, known_exceptions())
    found = cycles(edges)
    chains = [
        graph.find_shortest_chain(f"drx.{a}", f"drx.{b}", as_packages=True)
        for group in found
        for a, b in zip(group, group[1:] + group[:1], strict=True)
    ]
    assert found == [], f"package cycles {found}; chains: {chains}"


def test_the_cycle_check_sees_an_import_inside_a_function(graph: grimp.ImportGraph) -> None:
    """A back edge from the simulator to the CLI (as an import inside a function would add) is a
    cycle the check reports."""
    edges = package_edges(graph, known_exceptions())
    assert "sim" in edges.get("cli", set())
    edges.setdefault("sim", set()).add("cli")
    assert any({"cli", "sim"} <= set(group) for group in cycles(edges))
