"""End-to-end training speed: environment steps per second, updates and evaluations included.

For each drx network (``compact``, ``shallow``, ``deep``) it trains DeepRacer's
default car (10 actions) with DeepRacer's default hyperparameters (batch 64,
10 epochs, 20 episodes per iteration, Huber loss...) on ``reinvent_base`` with
the centre-line reward, through drx's trainer, for a wall-clock budget, and
counts training steps over wall time at the end of the last iteration whose update ran whole
(one cut short by the time limit is not counted).
In the same run it trains SB3's stock ``PPO("CnnPolicy")`` (NatureCNN, the
``shallow`` layout) on the same environment with the same batch size, epochs
and learning rate (2048 steps per update, SB3's default) and prints each
network's ratio to it. It also prints the core count, torch's thread count and
the machine's load average, since the figures depend on them (other
processes on the cores slow a run down, multi-threaded torch most of all), and
steps per CPU-second of the process (all its threads: torch's and OpenCV's).

With ``--rollout-workers 1 2 4`` each drx network trains once per worker count and round
(training episodes sampled by that many processes, :mod:`drx.train.rollout`): ``--repeats R``
rounds (default 2), each running every worker count in turn for ``--iterations`` whole
iterations (default 1), so that the settings share the machine's load alike. It prints each
run's steps/s with where its time went (sampling, update, evaluation; the workers' start-up
is printed but not counted, as it is paid once per job), then per setting the median steps/s,
and per network the median over rounds of the ratio of 2 workers to 1, beside the bound
Amdahl's law puts on it from the one-worker run's update and evaluation share (what perfect
sampling with K workers would give: ``1 / (fixed + sampling / K)``), and the ratio of the
sampling phases alone: seeded per episode, one worker and K drive the very same episodes and
update alike, so only their speed differs (on a shared machine the update's time varies with
the load far more than the workers change it). Without ``--networks`` it then trains
``shallow`` only (the issue's figure). Odd rounds run the counts in reverse order. Duration on
2 cores (one ``shallow`` iteration is ~35 s, mostly its update, plus each setting's start-up):
``--rollout-workers 1 2`` about 2.5 minutes, ``1 2 4`` about 3.5-5 (``--repeats 1``: 2-2.5).

On a busy machine one ``shallow`` iteration can outlast ``--seconds``; ``--iterations N``
trains each drx setting for N whole iterations instead (``--seconds`` then only caps it),
and SB3 for at least one whole rollout and update.

Run: ``python benchmarks/train_throughput.py [--seconds 90] [--threads N] [--networks compact,sb3]
[--rollout-workers 1 2 4] [--iterations N] [--repeats R]``.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import tempfile
import time
from pathlib import Path

import gymnasium as gym

# What `drx train` runs with (drx/train/__init__.py); set before torch loads, so SB3's run in this
# process gets it too and the comparison stays like for like.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

import torch as th  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SHARED_TRACK = ROOT.parent / "shared" / "tracks" / "reinvent_base.npy"


def track_path() -> str:
    """``reinvent_base`` from ../shared/tracks when present, else the project's oval."""
    return str(SHARED_TRACK) if SHARED_TRACK.is_file() else "oval"


def make_env_factory(network: str):  # noqa: ANN201 - a small closure factory
    """Env factory for the default car with ``network``."""
    from drx.sim.registration import ENV_ID, register_envs
    from drx.vehicle import Vehicle, default_vehicle

    register_envs()
    car = Vehicle(name="default", actions=default_vehicle().actions, network=network)
    reward = ROOT / "rewards" / "follow_center_line.py"

    def make(mode: str) -> gym.Env:
        return gym.make(
            ENV_ID,
            track=track_path(),
            vehicle=car,
            reward_function=str(reward) if reward.is_file() else None,
            mode=mode,
            disable_env_checker=True,
        )

    return car, make


def drx_steps_per_second(
    network: str, seconds: float, threads: int, seed: int, workers: int = 1, iterations: int | None = None
) -> dict:
    """Train with drx's trainer for about ``seconds``; steps/s at the end of the last iteration."""
    from drx.settings.hyperparameters import Hyperparameters
    from drx.settings.stop import StopConditions
    from drx.train.trainer import Trainer, TrainingSpec

    car, make = make_env_factory(network)
    with tempfile.TemporaryDirectory() as folder:
        spec = TrainingSpec(
            vehicle=car,
            hyperparameters=Hyperparameters(),
            stop=StopConditions(
                max_minutes=seconds / 60.0,
                max_episodes=None
                if iterations is None
                else iterations * Hyperparameters().episodes_per_iteration,
            ),
            folder=Path(folder),
            env_factory=make,
            seed=seed,
            threads=threads,
            rollout_workers=workers,
        )
        built = time.monotonic()
        trainer = Trainer(spec)
        startup = time.monotonic() - built
        start, cpu_start = time.monotonic(), time.process_time()
        result = trainer.run()
        wall, cpu = time.monotonic() - start, time.process_time() - cpu_start
    # Whole updates only: an update cut short at the time limit (only ever the last) would
    # flatter the figure; totals are cumulative, so the last whole iteration's are the figure.
    done = [s for s in result.summaries if not s.extra.get("update_cut")]
    label = network if workers == 1 else f"{network} x{workers}"
    if not done:
        return {"network": label, "workers": workers, "steps": result.steps, "seconds": wall,
                "steps_per_second": None}  # fmt: skip
    secs = done[-1].elapsed_seconds
    return {
        "network": label,
        "base_network": network,
        "workers": workers,
        "threads": trainer.threads,
        "iterations": len(done),
        "startup_seconds": round(startup, 1),
        "sampling_seconds": round(sum(s.extra.get("collect_seconds", 0.0) for s in done), 1),
        "update_seconds": round(sum(s.extra.get("update_seconds", 0.0) for s in done), 1),
        "eval_seconds": round(sum(s.extra.get("eval_seconds", 0.0) for s in done), 1),
        "steps": done[-1].steps,
        "seconds": round(secs, 1),
        "steps_per_second": done[-1].steps / secs,
        "steps_per_cpu_second": result.steps / cpu,
    }


def sb3_steps_per_second(seconds: float, threads: int, seed: int, rounds: int | None = None) -> dict:
    """SB3's stock PPO with CnnPolicy on the same env; steps/s over whole rollout+update rounds."""
    from stable_baselines3 import PPO

    _, make = make_env_factory("shallow")
    th.set_num_threads(threads)
    model = PPO(
        "CnnPolicy",
        make("training"),
        batch_size=64,
        n_epochs=10,
        learning_rate=3e-4,
        seed=seed,
        device="cpu",
        verbose=0,
    )
    start, cpu_start = time.monotonic(), time.process_time()
    done = 0
    while (done < rounds) if rounds else (time.monotonic() - start < seconds):
        done += 1
        model.learn(total_timesteps=model.n_steps, reset_num_timesteps=False)  # one rollout, one update
    secs, cpu = time.monotonic() - start, time.process_time() - cpu_start
    return {
        "network": "sb3 CnnPolicy",
        "threads": threads,
        "steps": model.num_timesteps,
        "seconds": round(secs, 1),
        "steps_per_second": model.num_timesteps / secs,
        "steps_per_cpu_second": model.num_timesteps / cpu,
    }


def _median(values: list[float]) -> float | None:
    return statistics.median(values) if values else None


def _print_row(row: dict) -> None:
    split = (
        f"; sampling {row['sampling_seconds']} s, update {row['update_seconds']} s, "
        f"evaluation {row['eval_seconds']} s, start-up {row['startup_seconds']} s (not counted)"
        if "sampling_seconds" in row
        else ""
    )
    print(
        f"  {row['network']:>14}: {row['steps_per_second'] or 0:7.1f} steps/s "
        f"({row['steps']} steps in {row['seconds']} s, {row.get('threads', '?')} thread(s), "
        f"load {row['load_average']}{split}; "
        f"{row.get('steps_per_cpu_second') or 0:.1f} steps per CPU-second of the trainer)",
        flush=True,
    )


def _worker_summary(rows: list[dict], networks: list[str], counts: list[int]) -> dict:
    """Median steps/s per setting, and per network the median ratio of 2 workers to 1 over rounds."""
    out: dict = {"median_steps_per_second": {}, "ratio_2_vs_1": {}, "ratios_by_round": {}}
    print("medians over rounds:")
    for name in networks:
        for k in counts:
            sps = [r["steps_per_second"] for r in rows if r.get("base_network") == name and r["workers"] == k]
            med = _median([v for v in sps if v])
            out["median_steps_per_second"][f"{name} x{k}"] = med
            print(f"  {name} x{k}: {med or 0:.1f} steps/s (runs: {', '.join(f'{v or 0:.1f}' for v in sps)})")
        one = [r for r in rows if r.get("base_network") == name and r["workers"] == 1]
        if one and one[0].get("sampling_seconds") is not None:
            busy = [r["sampling_seconds"] / max(r["seconds"], 1e-9) for r in one]
            share = _median(busy) or 0.0
            bounds = ", ".join(f"x{k} {1 / (1 - share + share / k):.2f}x" for k in counts if k > 1)
            print(
                f"  {name}: sampling is {100 * share:.0f}% of one worker's time; "
                f"K workers sampling K times faster, all else as with one, would give {bounds}"
            )
        ratios, sampling = [], []
        for rnd in sorted({r["round"] for r in rows}):
            by_k = {r["workers"]: r for r in rows if r.get("base_network") == name and r["round"] == rnd}
            if by_k.get(1, {}).get("steps_per_second") and by_k.get(2, {}).get("steps_per_second"):
                ratios.append(by_k[2]["steps_per_second"] / by_k[1]["steps_per_second"])
                # The same episodes in both (seeded per episode), so sampling time compares directly.
                if by_k[2].get("sampling_seconds"):
                    sampling.append(by_k[1]["sampling_seconds"] / by_k[2]["sampling_seconds"])
        if sampling:
            out.setdefault("sampling_2_vs_1", {})[name] = _median(sampling)
            print(
                f"  {name}: sampling phase, 2 workers vs 1: {_median(sampling):.2f}x "
                f"(rounds: {', '.join(f'{v:.2f}' for v in sampling)})"
            )
        if ratios:
            out["ratio_2_vs_1"][name] = _median(ratios)
            out["ratios_by_round"][name] = ratios
            print(
                f"  {name}: 2 rollout workers vs 1: {_median(ratios):.2f}x "
                f"(median of {len(ratios)} round(s): {', '.join(f'{v:.2f}' for v in ratios)})"
            )
    return out


def main() -> None:
    """Run the benchmark and print a table (and optional JSON)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=90.0, help="wall-clock budget per network")
    parser.add_argument(
        "--threads", type=int, default=len(os.sched_getaffinity(0)), help="torch threads a run may use"
    )
    parser.add_argument(
        "--networks", help="default: compact,shallow,deep,sb3; shallow when comparing workers"
    )
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", type=Path, help="also write the results here")
    parser.add_argument(
        "--iterations",
        type=int,
        help="train each drx setting for this many whole iterations instead (--seconds stays a cap); "
        "default 1 when comparing worker counts",
    )
    parser.add_argument(
        "--rollout-workers",
        type=int,
        nargs="+",
        default=[1],
        help="worker counts to run each drx network with",
    )
    parser.add_argument(
        "--repeats", type=int, default=2, help="rounds over the worker counts when comparing them"
    )
    args = parser.parse_args()
    comparing = len(args.rollout_workers) > 1
    networks = (args.networks or ("shallow" if comparing else "compact,shallow,deep,sb3")).split(",")
    iterations = args.iterations or (1 if comparing else None)
    rounds = max(1, args.repeats) if comparing else 1
    cores = len(os.sched_getaffinity(0))
    print(
        f"cores: {cores}, torch threads allowed: {args.threads}, track: {Path(track_path()).stem}, "
        f"budget: {args.seconds:g} s per run, iterations per run: {iterations or 'as many as fit'}, "
        f"load average at start: {' / '.join(f'{v:.1f}' for v in os.getloadavg())}"
    )
    rows = []
    # Odd rounds run the worker counts in reverse, so that a load drifting during the run favours
    # no setting.
    runs = [
        (rnd, name, workers)
        for rnd in range(rounds)
        for name in networks
        for workers in ([1] if name == "sb3" else args.rollout_workers[:: -1 if rnd % 2 else 1])
        if not (name == "sb3" and rnd > 0)
    ]
    for rnd, name, workers in runs:
        row = (
            sb3_steps_per_second(args.seconds, args.threads, args.seed, 1 if iterations else None)
            if name == "sb3"
            else drx_steps_per_second(name, args.seconds, args.threads, args.seed, workers, iterations)
        )
        row["round"] = rnd
        row["load_average"] = round(os.getloadavg()[0], 1)
        rows.append(row)
        _print_row(row)
    base = next((r["steps_per_second"] for r in rows if r["network"] == "sb3 CnnPolicy"), None)
    if base:
        print("ratio to SB3's stock CnnPolicy:")
        for r in rows:
            if r["steps_per_second"]:
                r["ratio_to_sb3"] = r["steps_per_second"] / base
                print(f"  {r['network']:>14}: {r['ratio_to_sb3']:.1f}x")
    summary = (
        _worker_summary(rows, [n for n in networks if n != "sb3"], args.rollout_workers) if comparing else {}
    )
    print(f"load average at the end: {' / '.join(f'{v:.1f}' for v in os.getloadavg())}")
    if args.json:
        args.json.write_text(
            json.dumps({"cores": cores, "threads": args.threads, "rows": rows, **summary}, indent=2)
        )


if __name__ == "__main__":
    main()
