"""An action space from the racing line against DeepRacer's grid: the same track, reward and minutes.

The fastest virtual racers derive their discrete actions from the track's racing line
(cdthompson/deepracer-k1999-race-lines; dgnzlz/Capstone_AWS_DeepRacer's
``RaceLine_Speed_ActionSpace.ipynb``): ``drx garage add NAME --from-racing-line TRACK`` does that
with drx's own line and car model (``drx/evaluate/action_space.py``). This benchmark trains two cars
as a user would, through the CLI in a fresh data home each, and races them:

- ``line``: ``--from-racing-line TRACK --actions 15 --max-speed 4`` (15 actions clustered from the line);
- ``grid``: DeepRacer's grid with as many actions to the same top speed, ``--max-steering 30
  --steering-levels 5 --max-speed 4 --speed-levels 3`` (15 actions; ``race_pace.py``'s discrete car).
  The console's default 10 actions top out at 1 m/s and would race another car, not another action space.

Both train with the same reward (default ``rewards/pursuit.py``: progress per step plus the speed
squared, which pays for pace), ``race_pace.py``'s DeepRacer hyperparameters (batch 128, learning rate
0.0003, discount 0.995, Huber loss, 25 episodes per iteration, 10 epochs), ``drx train --max-minutes M
--seed S``, then ``drx evaluate --laps 3 --seed S`` drives the **best** and the **last** checkpoint.
The table gives per car and checkpoint: fastest and mean lap (of the completed laps), laps completed,
off-tracks, steps trained, the car's theoretical best lap (``drx track best-lap``), with the core count
and the load average at the start and the end.

Run: ``python benchmarks/action_space.py [--minutes 10] [--track reInvent2019_wide_cw]
[--reward rewards/pursuit.py] [--actions 15] [--max-speed 4] [--seed 0] [--parallel 2] [--json FILE]``.
``--parallel 2`` trains both cars at once, one per core (the compact network's update uses one
thread); ``--parallel 1`` one after the other.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import json
import os
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from race_pace import Home  # the fresh data home and its CLI, as race_pace.py runs them

ROOT = Path(__file__).resolve().parents[1]
TRACK = "reInvent2019_wide_cw"
REWARD = ROOT / "rewards" / "pursuit.py"
HYPERPARAMETERS = (
    "--batch-size", "128", "--lr", "0.0003", "--discount", "0.995", "--loss", "huber",
    "--episodes-per-iteration", "25", "--epochs", "10",
)  # fmt: skip
CARS = ("line", "grid")


@dataclass
class Outcome:
    """What one car's run left: its actions, its training and the time trials of both checkpoints."""

    car: str
    actions: list[tuple[float, float]] = field(default_factory=list)
    minutes: float = 0.0
    steps: int = 0
    iterations: int = 0
    stop_reason: str | None = None
    theoretical_best: float | None = None
    trials: dict[str, dict[str, Any]] = field(default_factory=dict)


def car_options(car: str, args: argparse.Namespace) -> tuple[str, ...]:
    """``drx garage add`` options of ``car``: the racing line's actions or the grid to the same top speed.

    :param car: ``line`` or ``grid``.
    :param args: the benchmark's options (track, action count, top speed).
    """
    if car == "line":
        return (
            "--from-racing-line",
            args.track,
            "--actions",
            str(args.actions),
            "--max-speed",
            f"{args.max_speed:g}",
        )
    return ("--max-steering", "30", "--steering-levels", "5", "--max-speed", f"{args.max_speed:g}",
            "--speed-levels", "3")  # fmt: skip


def run_car(car: str, args: argparse.Namespace) -> Outcome:
    """Train ``car`` in a fresh data home and time-trial its best and last checkpoints.

    :param car: ``line`` or ``grid``.
    :param args: the benchmark's options.
    """
    out = Outcome(car)
    with tempfile.TemporaryDirectory(prefix=f"drx-action-space-{car}-") as folder:
        home = Home(folder)
        added = home.drx("garage", "add", f"{car}-car", *car_options(car, args))
        out.actions = [(a["steering_angle"], a["speed"]) for a in added["action_space"]]
        home.drx("model", "create", car, "--car", f"{car}-car", "--track", args.track, "--reward",
                 str(args.reward), *HYPERPARAMETERS, "--max-minutes", f"{args.minutes:g}")  # fmt: skip
        started = time.monotonic()
        trained = home.drx("train", car, "--max-minutes", f"{args.minutes:g}", "--seed", str(args.seed))
        out.minutes = (time.monotonic() - started) / 60.0
        out.steps = int(trained.get("steps") or 0)
        out.iterations = int(trained.get("iterations") or 0)
        out.stop_reason = trained.get("stop_reason")
        out.theoretical_best = home.drx("track", "best-lap", args.track, "--car", f"{car}-car").get(
            "lap_time"
        )
        for checkpoint in ("best", "last"):
            trial = home.drx(
                "evaluate", car, "--laps", "3", "--seed", str(args.seed), "--checkpoint", checkpoint
            )
            out.trials[checkpoint] = {
                "iteration": trial.get("checkpoint_iteration"),
                "laps_completed": trial.get("laps_completed"),
                "fastest": trial.get("fastest_lap"),
                "average": trial.get("average_lap"),
                "off_track": trial.get("off_track_count"),
            }
    print(f"  {car}: trained {out.steps} steps in {out.minutes:.1f} min", flush=True)
    return out


def _s(value: float | None, spec: str = ".2f") -> str:
    return "-" if value is None else format(value, spec)


def table(outcomes: list[Outcome]) -> str:
    """The results as a Markdown table, one row per car and checkpoint.

    :param outcomes: the cars' runs.
    """
    rows = [
        "| car | checkpoint | fastest lap | mean lap | laps completed | off-tracks | steps trained "
        "| best lap |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for o in outcomes:
        for checkpoint, t in o.trials.items():
            rows.append(
                f"| {o.car} ({len(o.actions)} actions) | {checkpoint} (iteration {t.get('iteration')}) | "
                f"{_s(t.get('fastest'))} s | {_s(t.get('average'))} s | {t.get('laps_completed')}/3 | "
                f"{t.get('off_track')} | {o.steps:,} ({o.iterations} iterations, {o.minutes:.1f} min) | "
                f"{_s(o.theoretical_best)} s |"
            )
    return "\n".join(rows)


def main() -> None:
    """Train both cars and print the table."""
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--minutes", type=float, default=10.0, help="training minutes of each car")
    parser.add_argument("--track", default=TRACK)
    parser.add_argument("--reward", type=Path, default=REWARD)
    parser.add_argument("--actions", type=int, default=15, help="the racing-line car's action count")
    parser.add_argument("--max-speed", type=float, default=4.0, help="both cars' top speed [m/s]")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--parallel", type=int, choices=(1, 2), default=2, help="cars trained at once")
    parser.add_argument("--json", type=Path, help="also write the outcomes to this JSON file")
    args = parser.parse_args()
    if args.minutes <= 0:
        parser.error("--minutes must be above 0.")
    args.reward = args.reward.resolve()
    if not args.reward.is_file():
        parser.error(f"--reward {str(args.reward)!r} is not a file; give a reward_function .py file.")
    cores = len(os.sched_getaffinity(0))
    start_load = os.getloadavg()
    print(
        f"action space on {args.track} with {args.reward.name}: the racing line's {args.actions} actions "
        f"against a 15-action grid, both to {args.max_speed:g} m/s; {args.minutes:g} min each, seed "
        f"{args.seed}; cores: {cores}, {args.parallel} at once; load average at the start: "
        f"{start_load[0]:.1f} (1 min), {start_load[2]:.1f} (15 min)",
        flush=True,
    )
    with concurrent.futures.ThreadPoolExecutor(max_workers=args.parallel) as pool:
        outcomes = list(pool.map(lambda car: run_car(car, args), CARS))
    end_load = os.getloadavg()
    print(f"load average at the end: {end_load[0]:.1f} (1 min), {end_load[2]:.1f} (15 min)")
    for o in outcomes:
        print(
            f"  {o.car} actions (steering deg, speed m/s): "
            + ", ".join(f"({s:g}, {v:g})" for s, v in o.actions)
        )
    print(table(outcomes))
    if args.json:
        args.json.write_text(json.dumps([o.__dict__ for o in outcomes], indent=2))


if __name__ == "__main__":
    main()
