"""Wall time of the CLI's everyday commands, each a fresh process: median of N runs (issue 40's
target: 0.25 s or less each on the 2-core machine; issue 16's was 0.7 s).

Runs ``drx --help``, ``drx model list``, ``garage list``, ``leaderboard``, ``jobs list``, ``info`` and
``track list`` in a scratch data home (``DRX_HOME``, set up by one untimed run of each, so the
registry exists and the tracks' facts are cached), with output to a pipe, and prints each command's
median wall time and spread, its median CPU time (user + system: on a loaded machine it grows less
than the wall time does), and the load average before and after.

With ``--base REV`` it times the same commands of git revision ``REV`` too (its files exported to a
temporary folder, run with this Python: a change of dependencies is not compared), alternating the
two trees run by run (odd runs the other way round) so both share the machine's load alike, each
with its own data home, and prints each command's median before and after side by side.

Usage: ``python benchmarks/cli_startup.py [--runs 7] [--base REV] [--json FILE]``
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
COMMANDS = (
    ["--help"], ["model", "list"], ["garage", "list"], ["leaderboard"], ["jobs", "list"], ["info"],
    ["track", "list"],
)  # fmt: skip
TARGET_SECONDS = 0.25


def time_command(argv: list[str], env: dict[str, str], cwd: Path) -> tuple[float, float]:
    """Seconds one run of ``argv`` in ``cwd`` takes, start to exit, and the CPU seconds it used;
    fails loudly on a non-zero exit."""
    start = time.perf_counter()
    process = subprocess.Popen(argv, env=env, cwd=cwd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(process.pid, 0)
    elapsed = time.perf_counter() - start
    stderr = process.stderr.read().decode(errors="replace") if process.stderr else ""
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(
            f"{' '.join(argv)} exited {os.waitstatus_to_exitcode(status)}: {stderr.strip()[:300]}"
        )
    return elapsed, usage.ru_utime + usage.ru_stime


def is_revision(revision: str) -> bool:
    """Whether ``revision`` names a commit of this repository."""
    check = ["git", "-C", str(ROOT), "rev-parse", "--verify", "--quiet", f"{revision}^{{commit}}"]
    return subprocess.run(check, capture_output=True, check=False).returncode == 0


def export_revision(revision: str, folder: Path) -> Path:
    """The files of git revision ``revision`` under ``folder`` (``git archive``: the repository's
    worktrees and branches are left alone)."""
    archive = folder / "base.tar"
    with archive.open("wb") as out:
        subprocess.run(["git", "-C", str(ROOT), "archive", revision], stdout=out, check=True)
    tree = folder / "base"
    with tarfile.open(archive) as tar:
        tar.extractall(tree, filter="data")
    return tree


class Tree:
    """One revision of drx: its source folder and its own scratch data home."""

    def __init__(self, name: str, source: Path, home: Path) -> None:
        self.name = name
        self.source = source  # the working folder too: ``python -m`` puts it first on the path
        self.env = {**os.environ, "DRX_HOME": str(home), "COLUMNS": "80", "PYTHONPATH": str(source)}
        self.env.pop("DRX_DATABASE_URL", None)
        self.argv = [sys.executable, "-m", "drx.cli.main"]
        self.runs: dict[str, list[tuple[float, float]]] = {}

    def prepare(self) -> None:
        """Create the registry and cache the tracks' facts (not timed)."""
        for command in COMMANDS:
            time_command([*self.argv, *command], self.env, self.source)

    def time(self, command: list[str]) -> None:
        timed = time_command([*self.argv, *command], self.env, self.source)
        self.runs.setdefault(label(command), []).append(timed)

    def median(self, command: list[str]) -> tuple[float, float]:
        runs = self.runs[label(command)]
        return statistics.median(r[0] for r in runs), statistics.median(r[1] for r in runs)


def label(command: list[str]) -> str:
    return "drx " + " ".join(command)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=int, default=7, help="timed runs per command and tree (median)")
    parser.add_argument("--base", default=None, help="a git revision to time beside this tree")
    parser.add_argument("--json", type=Path, default=None, help="also write the figures to this file")
    args = parser.parse_args()
    if args.runs < 1:
        parser.error(f"--runs {args.runs} is below 1; give 1 or more.")
    if args.base is not None and not is_revision(args.base):
        parser.error(f"--base {args.base!r} is not a git revision here; give a commit, e.g. HEAD~1 or main.")
    with tempfile.TemporaryDirectory(prefix="drx-cli-startup-") as scratch:
        folder = Path(scratch)
        trees = [Tree("after", ROOT, folder / "home-after")]
        if args.base:
            trees.insert(0, Tree("before", export_revision(args.base, folder), folder / "home-before"))
        for tree in trees:
            tree.prepare()
        before = os.getloadavg()
        for command in COMMANDS:
            for run in range(args.runs):
                for tree in trees if run % 2 == 0 else trees[::-1]:
                    tree.time(command)
    load = os.getloadavg()
    report(trees, args, before, load)


def report(
    trees: list[Tree], args: argparse.Namespace, before: tuple[float, ...], load: tuple[float, ...]
) -> None:
    """Print each command's medians (before and after with ``--base``) and write ``--json``."""
    base = f"; before: {args.base}, after: this tree" if args.base else ""
    print(f"cores: {os.cpu_count()}; {args.runs} runs each, median wall (cpu){base}; load {before[0]:.2f}")
    head = "".join(f"{t.name:>18s}" for t in trees)
    print(f"     {'command':18s}{head}")
    figures: dict[str, dict[str, dict[str, object]]] = {}
    for command in COMMANDS:
        cells, verdict = [], "ok  "
        for tree in trees:
            wall, cpu = tree.median(command)
            cells.append(f"{wall:8.3f} s ({cpu:.3f})")
            figures.setdefault(label(command), {})[tree.name] = {
                "median_s": wall, "cpu_s": cpu, "runs": [r[0] for r in tree.runs[label(command)]],
            }  # fmt: skip
            if tree.name == "after" and wall > TARGET_SECONDS:
                verdict = "MISS"
        print(f"{verdict} {label(command):18s}" + "".join(f"{c:>18s}" for c in cells))
    print(f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} (target: each {TARGET_SECONDS} s or less)")
    if args.json:
        args.json.write_text(json.dumps({"commands": figures, "load_before": before, "load": load}, indent=2))


if __name__ == "__main__":
    main()
