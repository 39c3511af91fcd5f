"""Wall-clock minutes from scratch until a checkpoint laps the track 3 times out of 3.

DeepRacer's default car (10 actions: 30 deg x 5, 1 m/s x 2) with drx's default
``compact`` network, DeepRacer's default hyperparameters and the sample
centre-line reward (``rewards/follow_center_line.py``) trains on
``reinvent_base`` (from ``../shared/tracks``, else the project's oval). After
every iteration the trainer runs 3 evaluation episodes from the start line with
the most probable action; the clock stops at the first checkpoint whose 3
evaluation episodes all complete the lap without leaving the track (the
trainer's ``target`` stop condition with K = 1). The wall time includes
everything: building the model, training episodes, updates, evaluations and
checkpoints. Median over seeds; a seed that does not get there within
``--max-minutes`` counts as "more than" that. The simulator and the policy are
deterministic in evaluation, so the 3 laps are the same lap; ``--consecutive K``
asks for K iterations in a row with 3/3 laps, a stricter figure.

``--defaults`` measures what a new user gets instead: for each seed it runs the README's
commands in a fresh data home, with every default (the garage car, the model's
hyperparameters, network and rollout workers)::

    drx garage add c
    drx model create m --car c --track reinvent_base --reward rewards/follow_center_line.py
    drx train m --max-minutes 10 --seed S --target-iterations 1

The clock is the wall time of ``drx train`` (process start to exit: imports, set-up,
training, evaluations, checkpoints). ``--target-iterations 1`` only ends the run at the
first checkpoint whose 3 evaluation laps from the start line all complete without leaving
the track, which is the figure; the training up to it is the same as without it. Then
``drx evaluate m --laps 3`` drives the model's best checkpoint as a time trial and the
script prints its laps and off-tracks.

Run: ``python benchmarks/time_to_lap.py [--seeds 3] [--max-minutes 20] [--threads N] [--consecutive K]``
or ``python benchmarks/time_to_lap.py --defaults [--seeds 3] [--max-minutes 10]``.
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

ROOT = Path(__file__).resolve().parents[1]
SHARED_TRACK = ROOT.parent / "shared" / "tracks" / "reinvent_base.npy"


def track_path(name: str) -> str:
    """A route from ../shared/tracks by name, else the name itself (a project track or a path)."""
    shared = SHARED_TRACK.parent / f"{name}.npy"
    return str(shared) if shared.is_file() else name


def run_seed(
    seed: int, max_minutes: float, threads: int, network: str, episodes: int, track: str, consecutive: int = 1
) -> dict:
    """Train one seed until 3/3 evaluation laps or the time limit."""
    import gymnasium as gym

    from drx.settings.hyperparameters import Hyperparameters
    from drx.settings.stop import StopConditions
    from drx.sim.registration import ENV_ID, register_envs
    from drx.train.trainer import Trainer, TrainingSpec
    from drx.vehicle import Vehicle, default_vehicle

    register_envs()
    car = Vehicle(name="default", actions=default_vehicle().actions, network=network)
    reward = str(ROOT / "rewards" / "follow_center_line.py")

    def make(mode: str) -> gym.Env:
        return gym.make(
            ENV_ID, track=track, vehicle=car, reward_function=reward, mode=mode, disable_env_checker=True
        )

    start = time.monotonic()
    with tempfile.TemporaryDirectory() as folder:
        spec = TrainingSpec(
            vehicle=car,
            hyperparameters=Hyperparameters(episodes_per_iteration=episodes),
            stop=StopConditions(max_minutes=max_minutes, target_iterations=consecutive),
            folder=Path(folder),
            env_factory=make,
            eval_episodes=3,
            seed=seed,
            threads=threads,
        )
        result = Trainer(spec).run()
    minutes = (time.monotonic() - start) / 60.0
    last = result.summaries[-1] if result.summaries else None
    lapped = result.stop_reason == "target"
    return {
        "seed": seed,
        "lapped": lapped,
        "minutes": round(minutes, 2),
        "iterations": len(result.summaries),
        "steps": result.steps,
        "episodes": result.episodes,
        "lap_time": last.eval_mean_lap_time if last and lapped else None,
        "best_eval_progress": max((s.eval_mean_progress or 0.0 for s in result.summaries), default=0.0),
        "load_average": round(os.getloadavg()[0], 1),
    }


def run_defaults_seed(seed: int, max_minutes: float, track: str) -> dict:
    """The README's commands with every default in a fresh data home; minutes of ``drx train``."""
    drx = [sys.executable, "-m", "drx.cli.main"]
    with tempfile.TemporaryDirectory() as home:
        env = {**os.environ, "DRX_HOME": home, "PYTHONPATH": str(ROOT)}

        def run(*args: str) -> subprocess.CompletedProcess[str]:
            done = subprocess.run([*drx, *args], capture_output=True, text=True, env=env, cwd=ROOT)
            if done.returncode != 0:
                raise SystemExit(f"drx {' '.join(args)} failed ({done.returncode}): {done.stderr}")
            return done

        run("garage", "add", "c")  # the track is DeepRacer's, shipped with drx: no import
        run("model", "create", "m", "--car", "c", "--track", track,
            "--reward", "rewards/follow_center_line.py")  # fmt: skip
        start = time.monotonic()
        trained = json.loads(
            run("train", "m", "--max-minutes", f"{max_minutes:g}", "--seed", str(seed),
                "--target-iterations", "1", "--json").stdout
        )  # fmt: skip
        minutes = (time.monotonic() - start) / 60.0
        shown = json.loads(run("model", "show", "m", "--json").stdout)
        trial = json.loads(run("evaluate", "m", "--laps", "3", "--seed", str(seed), "--json").stdout)
    return {
        "seed": seed,
        "lapped": trained["stop_reason"] == "target",
        "minutes": round(minutes, 2),
        "iterations": trained["iterations"],
        "steps": trained["steps"],
        "episodes": trained["episodes"],
        "network": shown["vehicle"].get("neural_network"),
        "rollout_workers": shown.get("rollout_workers"),
        "evaluate_laps": trial["laps_completed"],
        "evaluate_off_track": trial["off_track_count"],
        "evaluate_fastest_lap": trial["fastest_lap"],
        "load_average": round(os.getloadavg()[0], 1),
    }


def main_defaults(args: argparse.Namespace) -> None:
    """``--defaults``: the README's commands per seed, then the median."""
    print(
        f"cores: {len(os.sched_getaffinity(0))}, track: {args.track}, every default, "
        f"load average at start: {os.getloadavg()[0]:.1f}",
        flush=True,
    )
    rows = []
    for seed in range(args.first_seed, args.first_seed + args.seeds):
        row = run_defaults_seed(seed, args.max_minutes, args.track)
        rows.append(row)
        got = (
            f"3/3 laps after {row['minutes']:.1f} min"
            if row["lapped"]
            else f"no 3/3 in {row['minutes']:.1f} min"
        )
        print(
            f"  seed {seed}: {got} ({row['iterations']} iterations, {row['steps']} steps, network "
            f"{row['network']}, rollout workers {row['rollout_workers'] or 'automatic'}); "
            f"drx evaluate --laps 3: {row['evaluate_laps']} laps, {row['evaluate_off_track']} off-track, "
            f"fastest {row['evaluate_fastest_lap'] or 0:.2f} s; load {row['load_average']}",
            flush=True,
        )
    times = [r["minutes"] if r["lapped"] else float("inf") for r in rows]
    median = statistics.median(times)
    shown = f"{median:.1f} min" if median != float("inf") else f"more than {args.max_minutes:g} min"
    print(f"median time to a 3/3-lap model with all defaults: {shown} over {len(rows)} seed(s)")
    if args.json:
        args.json.write_text(json.dumps({"rows": rows, "median_minutes": median}, indent=2))


def main() -> None:
    """Run the seeds and print each and the median."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--max-minutes", type=float, help="per seed [default: 20; 10 with --defaults]")
    parser.add_argument("--threads", type=int, default=len(os.sched_getaffinity(0)))
    parser.add_argument("--network", default="compact")
    parser.add_argument("--track", default="reinvent_base")  # DeepRacer's re:Invent 2018, shipped
    parser.add_argument("--episodes-per-iteration", type=int, default=20, help="DeepRacer's default: 20")
    parser.add_argument(
        "--consecutive", type=int, default=1, help="iterations in a row with 3/3 laps (stricter than 1)"
    )
    parser.add_argument("--json", type=Path)
    parser.add_argument(
        "--defaults",
        action="store_true",
        help="the README's commands with every default (drx CLI, fresh home)",
    )
    args = parser.parse_args()
    if args.max_minutes is None:
        args.max_minutes = 10.0 if args.defaults else 20.0
    if args.defaults:
        main_defaults(args)
        return
    track = args.track
    print(
        f"cores: {len(os.sched_getaffinity(0))}, torch threads allowed: {args.threads}, track: {track}, "
        f"network: {args.network}, load average at start: {os.getloadavg()[0]:.1f}",
        flush=True,
    )
    rows = []
    for seed in range(args.first_seed, args.first_seed + args.seeds):
        row = run_seed(
            seed,
            args.max_minutes,
            args.threads,
            args.network,
            args.episodes_per_iteration,
            track_path(args.track),
            args.consecutive,
        )
        rows.append(row)
        got = (
            f"3/3 laps after {row['minutes']:.1f} min"
            if row["lapped"]
            else f"no 3/3 in {row['minutes']:.1f} min"
        )
        lap = f", lap {row['lap_time']:.2f} s" if row["lap_time"] else ""
        print(
            f"  seed {seed}: {got}{lap} ({row['iterations']} iterations, {row['steps']} steps, "
            f"best eval progress {row['best_eval_progress']:.0f}%, load {row['load_average']})",
            flush=True,
        )
    times = [r["minutes"] if r["lapped"] else float("inf") for r in rows]
    median = statistics.median(times)
    shown = f"{median:.1f} min" if median != float("inf") else f"more than {args.max_minutes:g} min"
    what = (
        "a 3/3-lap checkpoint" if args.consecutive == 1 else f"{args.consecutive} 3/3-lap iterations in a row"
    )
    print(f"median time to {what}: {shown} over {len(rows)} seed(s)")
    if args.json:
        args.json.write_text(json.dumps({"rows": rows, "median_minutes": median}, indent=2))


if __name__ == "__main__":
    main()
