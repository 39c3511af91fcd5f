"""A sweep run by several ``drx worker`` processes: wall time, trial states, pruned trials, the best.

In a throw-away data home (SQLite, or ``--database-url`` such as a PostgreSQL), it creates a
source model (compact network on the oval, 5 episodes per iteration), a sweep of ``--trials``
trials over the learning rate (1e-8..1e-3, log), PPO epochs and batch size with the median pruner
(1 startup trial, no warm-up), runs ``--workers`` workers until the queue is empty, and prints the
wall time, each trial's state, iterations and value, how many were pruned early (fewer iterations
than their stop condition allows), and whether the best trial's model row holds its parameters.

Run: ``python benchmarks/sweep_workers.py [--trials 6] [--workers 2] [--iterations 3]``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def main() -> None:
    """Run the benchmark and print its figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=6)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--iterations", type=int, default=3, help="iterations per trial (5 episodes each)")
    parser.add_argument("--database-url", default=None, help="a registry URL (emptied: never a real one)")
    args = parser.parse_args()

    home = Path(tempfile.mkdtemp(prefix="drx-sweep-bench-"))
    env = {**os.environ, "DRX_HOME": str(home), "DRX_TORCH_THREADS": "1"}
    if args.database_url:
        env["DRX_DATABASE_URL"] = args.database_url
    drx = [sys.executable, "-m", "drx.cli.main"]

    def run(*cmd: str) -> str:
        return subprocess.run([*drx, *cmd], env=env, check=True, capture_output=True, text=True).stdout

    run("model", "create", "base", "--network", "compact", "--track", "oval", "--episodes-per-iteration", "5",
        "--max-episodes", str(5 * args.iterations))  # fmt: skip
    run("sweep", "create", "bench", "--from", "base", "--trials", str(args.trials),
        "--param", "lr=1e-8:1e-3:log", "--param", "epochs=3,10", "--param", "batch-size=32,64",
        "--startup-trials", "1", "--warmup-iterations", "0")  # fmt: skip
    started = time.monotonic()
    workers = [
        subprocess.Popen([*drx, "worker", "--exit-when-idle"], env=env, stdout=subprocess.DEVNULL)
        for _ in range(args.workers)
    ]
    for w in workers:
        w.wait()
    wall = time.monotonic() - started
    data = json.loads(run("sweep", "show", "bench", "--json"))
    trials = data["trials"]
    print(f"{args.trials} trials x {args.iterations} iterations, {args.workers} workers: {wall:.0f} s wall")
    for t in trials:
        value = "-" if t["value"] is None else f"{t['value']:.1f}"
        params = ", ".join(
            f"{k}={v:.3g}" if isinstance(v, float) else f"{k}={v}" for k, v in t["params"].items()
        )
        print(
            f"  trial {t['number']} {t['model']:>9} {t['state']:>8} {t['iterations']} it {value:>6}  {params}"
        )
    early = [t for t in trials if t["state"] == "pruned" and t["iterations"] < args.iterations]
    print(f"distinct models: {len({t['model'] for t in trials})}, pruned early: {len(early)}")
    best = data["best"]
    if best is not None:
        shown = json.loads(run("model", "show", best["model"], "--json"))
        hp = shown["hyperparameters"]
        holds = (
            abs(hp["learning_rate"] - best["params"]["lr"]) <= 1e-12
            and hp["num_epochs"] == best["params"]["epochs"]
            and hp["batch_size"] == best["params"]["batch-size"]
        )
        print(f"best: trial {best['number']} ({best['model']}), progress {best['value']:.1f}%; "
              f"its model row holds its params: {holds}")  # fmt: skip
    print(f"picture: {data['png']}")


if __name__ == "__main__":
    main()
