"""Run one benchmark on two revisions of drx, alternately, and compare a figure it prints.

A figure measured before a change and another after it, minutes apart, also measures how busy
the machine was each time. This runs the same command in a checkout of ``--base`` (a git
revision, by default the last commit) and in the working tree, alternating ``--rounds`` times
(odd rounds the other way round), so both share the machine's load alike. Each run's output is
searched for ``--figure``, a regular expression whose first group is a number (for instance
``"drx: median ([0-9.]+) ms"``; with alternatives, the first group that matched); a run that
prints it more than once gives each match, in order,
as its own figure (``--label`` names them). It prints every round, the median of each figure per
tree, their ratio, the core count and the load average before and after.

The base checkout is a ``git worktree`` in a temporary folder, removed at the end; it runs with
this environment's Python and packages, so a change of dependencies is not compared. Both trees
run the working tree's ``benchmarks/`` (copied into the base checkout), so the same measuring code
times both revisions of ``drx`` and a benchmark written with the change can time the code before
it; ``--base-benchmarks`` keeps the base's own.

Run: ``python benchmarks/ab_revisions.py [--base HEAD] [--rounds 3] --figure REGEX [--label NAME ...]
[--higher-is-better] -- python benchmarks/sac_update.py --repeats 3``.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def run_in(tree: Path, command: list[str], pattern: re.Pattern[str]) -> list[float]:
    """The figures ``command`` prints when run in ``tree`` (its drx first on the import path)."""
    env = {**os.environ, "PYTHONPATH": str(tree)}
    argv = [sys.executable if part in ("python", "python3") else part for part in command]
    done = subprocess.run(argv, cwd=tree, env=env, capture_output=True, text=True, check=False)
    if done.returncode != 0:
        sys.exit(f"{' '.join(command)} failed in {tree} (exit {done.returncode}):\n{done.stderr[-2000:]}")
    # The first group that matched is the figure (alternatives may each have their own group); a
    # thousands separator (13,946 steps/s) is read through.
    figures = [
        float(next(g for g in m.groups() if g is not None).replace(",", ""))
        for m in pattern.finditer(done.stdout)
    ]
    if not figures:
        sys.exit(f"{' '.join(command)} printed nothing matching {pattern.pattern!r} in {tree}:\n"
                 f"{done.stdout}")  # fmt: skip
    return figures


def main() -> None:
    """Alternate the two trees and print the medians."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", default="HEAD", help="the git revision to compare against")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--figure", required=True, help="regex whose first group is the figure")
    parser.add_argument("--label", nargs="*", default=[], help="names of the figures, in order")
    parser.add_argument("--higher-is-better", action="store_true", help="e.g. steps/s (default: times)")
    parser.add_argument("--base-benchmarks", action="store_true", help="run the base's own benchmarks/")
    parser.add_argument("command", nargs=argparse.REMAINDER, help="after --: the benchmark to run")
    args = parser.parse_args()
    command = args.command[1:] if args.command[:1] == ["--"] else args.command
    if not command:
        parser.error("give the benchmark to run after --, e.g. -- python benchmarks/sac_update.py")
    if args.rounds < 1:
        parser.error(f"--rounds {args.rounds} is below 1; give 1 or more.")
    try:
        pattern = re.compile(args.figure)
    except re.error as err:
        parser.error(f"--figure {args.figure!r} is not a regular expression ({err}); give one with a group.")
    if pattern.groups < 1:
        parser.error(f"--figure {args.figure!r} has no group; put the number in one: ([0-9.]+).")
    if subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--verify", "--quiet", f"{args.base}^{{commit}}"],
                      capture_output=True, check=False).returncode != 0:  # fmt: skip
        parser.error(f"--base {args.base!r} is not a git revision here; give a commit, e.g. HEAD~1.")
    load_before = os.getloadavg()[0]
    with tempfile.TemporaryDirectory(prefix="drx-ab-") as folder:
        base = Path(folder) / "base"
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(base), args.base],
                       check=True, capture_output=True)  # fmt: skip
        if not args.base_benchmarks:
            shutil.copytree(ROOT / "benchmarks", base / "benchmarks", dirs_exist_ok=True)
        try:
            figures: dict[str, list[list[float]]] = {"base": [], "change": []}
            for round_ in range(args.rounds):
                order = [("base", base), ("change", ROOT)]
                for name, tree in order if round_ % 2 == 0 else order[::-1]:
                    got = run_in(tree, command, pattern)
                    figures[name].append(got)
                    print(f"round {round_ + 1} {name:>6}: {', '.join(f'{f:g}' for f in got)}", flush=True)
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(base)], check=False)
    count = min(len(runs) for tree_runs in figures.values() for runs in tree_runs)
    load_after = os.getloadavg()[0]
    print(
        f"\n{' '.join(command)}; base {args.base} against the working tree, {args.rounds} rounds; "
        f"cores {os.cpu_count()}, load average {load_before:.1f} before, {load_after:.1f} after"
    )
    for i in range(count):
        label = args.label[i] if i < len(args.label) else f"figure {i + 1}"
        base_m = statistics.median(runs[i] for runs in figures["base"])
        change_m = statistics.median(runs[i] for runs in figures["change"])
        gain = change_m / base_m if args.higher_is_better else base_m / change_m
        print(f"  {label}: base median {base_m:g}, change median {change_m:g}: {gain:.2f}x "
              f"{'faster' if gain >= 1 else 'slower'}")  # fmt: skip


if __name__ == "__main__":
    main()
