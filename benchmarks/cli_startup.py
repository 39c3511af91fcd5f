"""Wall time of the CLI's everyday commands, each a fresh process: median of N runs (issue 16's
target: under 0.7 s each on the 2-core machine).

Runs ``drx --help``, ``drx model list``, ``drx track list`` and ``drx info`` in a scratch data home
(``DRX_HOME``, set up by one untimed ``drx info`` so the registry exists), with output to a pipe, and
prints each command's median wall time and spread, its median CPU time (user + system: on a
loaded machine it grows less than the wall time does), and the load average before and after.

Usage: ``python benchmarks/cli_startup.py [--runs 5] [--json FILE]``
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

COMMANDS = (["--help"], ["model", "list"], ["track", "list"], ["info"])
TARGET_SECONDS = 0.7


def drx_command() -> list[str]:
    """The installed ``drx`` script beside this Python, else ``python -m drx.cli.main``."""
    script = Path(sys.executable).with_name("drx")
    return [str(script)] if script.is_file() else [sys.executable, "-m", "drx.cli.main"]


def time_command(argv: list[str], env: dict[str, str]) -> tuple[float, float]:
    """Seconds one run of ``argv`` takes, start to exit, and the CPU seconds it used; fails loudly
    on a non-zero exit."""
    start = time.perf_counter()
    process = subprocess.Popen(argv, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(process.pid, 0)
    elapsed = time.perf_counter() - start
    stderr = process.stderr.read().decode(errors="replace") if process.stderr else ""
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(
            f"{' '.join(argv)} exited {os.waitstatus_to_exitcode(status)}: {stderr.strip()[:300]}"
        )
    return elapsed, usage.ru_utime + usage.ru_stime


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=int, default=5, help="timed runs per command (median reported)")
    parser.add_argument("--json", type=Path, default=None, help="also write the figures to this file")
    args = parser.parse_args()
    drx = drx_command()
    figures = {}
    with tempfile.TemporaryDirectory(prefix="drx-cli-startup-") as home:
        env = {**os.environ, "DRX_HOME": home, "COLUMNS": "80"}
        for command in COMMANDS:  # creates the registry, caches the tracks' facts: not timed
            time_command([*drx, *command], env)
        before = os.getloadavg()
        print(f"cores: {os.cpu_count()}; {args.runs} runs each, median (min-max); load {before[0]:.2f}")
        for command in COMMANDS:
            runs = [time_command([*drx, *command], env) for _ in range(args.runs)]
            times, cpu = [r[0] for r in runs], [r[1] for r in runs]
            median = statistics.median(times)
            label = "drx " + " ".join(command)
            verdict = "ok  " if median < TARGET_SECONDS else "MISS"
            print(
                f"{verdict} {label:18s} {median:6.3f} s  ({min(times):.3f}-{max(times):.3f})  "
                f"cpu {statistics.median(cpu):.3f} s"
            )
            figures[label] = {"median_s": median, "runs": times, "cpu_s": cpu}
    load = os.getloadavg()
    print(f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f} (target: each under {TARGET_SECONDS} s)")
    if args.json:
        args.json.write_text(json.dumps({"commands": figures, "load_before": before, "load": load}, indent=2))


if __name__ == "__main__":
    main()
