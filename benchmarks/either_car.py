"""Models that race on either car: trained on simulator 5's car, 6's, or a car drawn between them each
episode (``--car-randomization``), each raced on both.

For every car setup (``--only``: ``compact`` PPO with a 15-action discrete grid to 3 m/s, ``shallow``
PPO continuous 0.5-3 m/s, ``sac`` continuous 0.5-3 m/s), every track (``--tracks``) and every way of
training (``v5``: simulator 5's car; ``v6``: 6's; ``random``: simulator 6 with car randomization), a
model is trained ``--minutes`` through the CLI in a fresh data home (``drx model create ... --simulator
--car-randomization``, ``drx train --max-minutes --seed``) with the centre-line reward, then its best
checkpoint races 3 laps on each car (``drx evaluate --simulator 5|6 --laps 3 --seed``). The table
gives, per model and car raced on: laps completed of 3, fastest and mean lap [s], off-tracks; and per
randomised model, its mean lap on each car against the model trained on that car alone (the goal:
3/3 laps on both, within 5 %). Prints the core count and the load.

    .venv/bin/python benchmarks/either_car.py [--only compact shallow sac] [--tracks T1 T2]
        [--minutes 10] [--parallel 2] [--seed 0] [--json FILE]
"""

from __future__ import annotations

import argparse
import concurrent.futures
import json
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

from race_pace import Home  # noqa: E402

CARS = {
    "compact": (("--max-steering", "30", "--steering-levels", "5", "--max-speed", "3", "--speed-levels", "3",
                 "--network", "compact"), ("--algo", "ppo")),
    "shallow": (("--continuous", "--max-steering", "30", "--min-speed", "0.5", "--max-speed", "3",
                 "--network", "shallow"), ("--algo", "ppo")),
    "sac": (("--continuous", "--max-steering", "30", "--min-speed", "0.5", "--max-speed", "3",
             "--network", "shallow"), ("--algo", "sac")),
}  # fmt: skip
TRAININGS = {"v5": ("--simulator", "5"), "v6": ("--simulator", "6"), "random": ("--simulator", "6",
                                                                             "--car-randomization")}
REWARD = ROOT / "rewards" / "follow_center_line.py"
GOAL = 1.05  # a randomised model's mean lap within 5 % of the one trained on that car alone


def run_one(car: str, track: str, training: str, args: argparse.Namespace) -> dict[str, Any]:
    """Train one model and race it on both cars, in a fresh data home."""
    with tempfile.TemporaryDirectory(prefix="drx-either-") as folder:
        home = Home(folder)
        garage, algo = CARS[car]
        home.drx("garage", "add", car, *garage)
        name = f"{car}-{training}"
        home.drx("model", "create", name, "--car", car, "--track", track, "--reward", str(REWARD), *algo,
                 *TRAININGS[training])  # fmt: skip
        started = time.perf_counter()
        home.drx("train", name, "--max-minutes", str(args.minutes), "--seed", str(args.seed))
        minutes = (time.perf_counter() - started) / 60.0
        races = {}
        for simulator in ("5", "6"):
            seed = str(args.seed)
            result = home.drx("evaluate", name, "--simulator", simulator, "--laps", "3", "--seed", seed)
            races[simulator] = {
                "laps": int(result["laps_completed"]),
                "fastest": result["fastest_lap"],
                "mean": result["average_lap"],
                "off_track": int(result["off_track_count"] or 0),
            }
        return {"car": car, "track": track, "training": training, "minutes": round(minutes, 1),
                "races": races}  # fmt: skip


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--only", nargs="+", choices=sorted(CARS), default=["compact", "shallow", "sac"])
    parser.add_argument("--tracks", nargs="+", default=["reinvent_base", "reInvent2019_wide_cw"])
    parser.add_argument("--trainings", nargs="+", choices=sorted(TRAININGS), default=list(TRAININGS))
    parser.add_argument("--minutes", type=float, default=10.0)
    parser.add_argument("--parallel", type=int, default=1)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    if args.minutes <= 0 or args.parallel < 1:
        print(f"--minutes {args.minutes:g} and --parallel {args.parallel} must be positive.")
        return 2
    load = os.getloadavg()[0]
    print(f"{os.cpu_count()} cores, load {load:.1f} at the start; {args.minutes:g} min per model")
    jobs = [(c, t, w) for c in args.only for t in args.tracks for w in args.trainings]
    with concurrent.futures.ThreadPoolExecutor(max_workers=args.parallel) as pool:
        rows = list(pool.map(lambda job: run_one(*job, args), jobs))
    print(f"load {os.getloadavg()[0]:.1f} at the end")
    print(f"{'car':8} {'track':22} {'trained':8} {'raced':5} {'laps':>4} {'fastest':>8} {'mean':>8} "
          f"{'off':>4}")  # fmt: skip
    for r in rows:
        for sim, race in r["races"].items():
            fastest = "-" if race["fastest"] is None else f"{race['fastest']:.2f}"
            mean = "-" if race["mean"] is None else f"{race['mean']:.2f}"
            print(f"{r['car']:8} {r['track']:22} {r['training']:8} v{sim:4} {race['laps']:>2}/3 {fastest:>8} "
                  f"{mean:>8} {race['off_track']:>4}")  # fmt: skip
    print("\nrandomised against trained on that car alone (mean lap ratio; goal 3/3 laps and <= 1.05):")
    by_key = {(r["car"], r["track"], r["training"]): r for r in rows}
    for (car, track, training), r in by_key.items():
        if training != "random":
            continue
        parts = []
        for sim in ("5", "6"):
            alone = by_key.get((car, track, f"v{sim}"))
            mine = r["races"][sim]
            if alone is None or mine["mean"] is None or alone["races"][sim]["mean"] is None:
                parts.append(f"v{sim}: {mine['laps']}/3 laps, no ratio")
                continue
            ratio = mine["mean"] / alone["races"][sim]["mean"]
            ok = mine["laps"] == 3 and ratio <= GOAL
            parts.append(f"v{sim}: {mine['laps']}/3 laps, {ratio:.3f}x {'ok' if ok else 'miss'}")
        print(f"  {car} on {track}: " + "; ".join(parts))
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())
