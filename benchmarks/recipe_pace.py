"""The race-pace recipe against the limit and the league (issue 41; ``race_pace.py --recipe``).

For each track and seed, in a fresh data home, as a racer runs it:
``drx model create rp --track T --recipe race-pace``, ``drx train rp --max-minutes M --seed S``, then
``drx evaluate rp --laps 3 --seed S`` on the **best** and the **last** checkpoint. Each fastest lap is
set against the theoretical best lap of DeepRacer's fastest car (continuous, +-30 deg, 0.5-4 m/s,
``drx track best-lap T --car fastest`` on the model's simulator) and against the fastest lap racers
drove in DeepRacer's simulator-5-era league (``../shared/DEEPRACER.md`` section 4b). The goals:
best within :data:`BEST_GOAL` of the theoretical lap, last within :data:`LAST_GOAL` of the best, on
every track and seed.

``--compare-kinds`` runs ``race-pace-discrete`` and ``race-pace-continuous`` side by side instead
(the measurement behind the recipe's choice of action space).
"""

from __future__ import annotations

import argparse
import concurrent.futures
import json
import os
import tempfile
import time
from dataclasses import dataclass, field
from typing import Any

from race_pace import Home, _s, ensure_track, run_health, time_trials

# The league's fastest laps [s] (simulator-5-era final leaderboards), by the route drx races.
LEAGUE = {
    "2024_reinvent_champ_ccw": 7.53,
    "caecer_loop": 9.21,
    "arctic_open": 11.60,
    "Albert": 13.41,
    "Belille": 16.06,
    "Austin": 16.40,
}
LEAGUE_TRACKS = ("2024_reinvent_champ_ccw", "caecer_loop", "arctic_open", "Albert")  # the four shortest
FASTEST_CAR = ("--continuous", "--max-steering", "30", "--min-speed", "0.5", "--max-speed", "4")
BEST_GOAL = 1.15  # the best checkpoint's fastest lap over the theoretical best lap
LAST_GOAL = 1.05  # the last checkpoint's fastest lap over the best's


@dataclass
class RecipeRun:
    """One recipe run: a track, a seed, its training and its two time trials."""

    recipe: str
    track: str
    seed: int
    minutes: float = 0.0
    steps: int = 0
    iterations: int = 0
    theoretical_best: float | None = None
    league: float | None = None
    health: dict[str, Any] = field(default_factory=dict)
    rollbacks: int = 0
    trials: dict[str, dict[str, Any]] = field(default_factory=dict)


def run_recipe(recipe: str, track: str, seed: int, args: argparse.Namespace) -> RecipeRun:
    """Create, train and time-trial one recipe model in a fresh data home."""
    out = RecipeRun(recipe, track, seed, league=LEAGUE.get(track))
    with tempfile.TemporaryDirectory(prefix="drx-recipe-pace-") as folder:
        home = Home(folder)
        ensure_track(home, track)
        extra: tuple[str, ...] = ()
        if args.lr_schedule is not None:
            extra = ("--lr-schedule", args.lr_schedule)
        home.drx("model", "create", "rp", "--track", track, "--recipe", recipe,
                 "--max-minutes", f"{args.minutes:g}", *extra)  # fmt: skip
        started = time.monotonic()
        trained = home.drx("train", "rp", "--max-minutes", f"{args.minutes:g}", "--seed", str(seed))
        out.minutes = (time.monotonic() - started) / 60.0
        out.steps = int(trained.get("steps") or 0)
        out.iterations = int(trained.get("iterations") or 0)
        out.health = run_health(home, "rp")
        out.rollbacks = int(out.health.get("rollbacks") or 0)
        home.drx("garage", "add", "fastest", *FASTEST_CAR)
        out.theoretical_best = home.drx("track", "best-lap", track, "--car", "fastest").get("lap_time")
        out.trials = time_trials(home, "rp", seed)
    print(f"  {run_text(out)}", flush=True)
    return out


def run_text(r: RecipeRun) -> str:
    """One run in a few lines: each checkpoint against the limit and the league, then last / best."""
    lines = []
    for checkpoint, t in r.trials.items():
        fastest = t.get("fastest")
        vs_limit = fastest / r.theoretical_best if fastest and r.theoretical_best else None
        vs_league = fastest / r.league if fastest and r.league else None
        lines.append(
            f"{r.track} seed {r.seed} {checkpoint:4s} it {t.get('iteration')!s:>4s}: "
            f"fastest {_s(fastest)} s (average {_s(t.get('average'))}), laps {t.get('laps_completed')}/3, "
            f"off-track {t.get('off_track')}; x{_s(vs_limit)} the limit {_s(r.theoretical_best)} s, "
            f"x{_s(vs_league)} the league's {_s(r.league)} s"
        )
    best, last = (r.trials.get(k, {}).get("fastest") for k in ("best", "last"))
    ratio = f"{last / best:.3f}" if best and last else "-"
    limit = f"{best / r.theoretical_best:.3f}" if best and r.theoretical_best else "-"
    lines.append(
        f"{r.track} seed {r.seed}: best/limit {limit} (goal {BEST_GOAL}), "
        f"last/best {ratio} (goal {LAST_GOAL}); {r.steps} steps in {r.minutes:.1f} min, "
        f"{r.iterations} iterations, {r.rollbacks} rollbacks to the best"
    )
    h = r.health
    if h.get("pace_by_quarter"):
        lines.append(f"{r.track} seed {r.seed}: evaluation laps' mean by quarter: "
                     + ", ".join(_s(t) for t in h["pace_by_quarter"]) + " s")  # fmt: skip
    return "\n  ".join(lines)


def table(runs: list[RecipeRun]) -> str:
    """The runs as a Markdown table (docs/RACING.md)."""
    head = (
        "| recipe | track | seed | best: fastest, off-track (iteration) | last: fastest, off-track | "
        "best / limit | last / best | x league | steps |\n|---|---|---|---|---|---|---|---|---|"
    )
    rows = []
    for r in runs:
        b, last = r.trials.get("best", {}), r.trials.get("last", {})
        bf, lf = b.get("fastest"), last.get("fastest")
        rows.append(
            f"| {r.recipe} | {r.track} | {r.seed} | "
            f"{_s(bf)} s, {b.get('off_track')} ({b.get('iteration')}) | "
            f"{_s(lf)} s, {last.get('off_track')} | "
            f"{_s(bf / r.theoretical_best if bf and r.theoretical_best else None, '.3f')} "
            f"({_s(r.theoretical_best)} s) | {_s(lf / bf if bf and lf else None, '.3f')} | "
            f"{_s(bf / r.league if bf and r.league else None)} ({_s(r.league)} s) | {r.steps:,} |"
        )
    return "\n".join([head, *rows])


def main(argv: list[str] | None = None) -> None:
    """Run the recipe on the tracks and seeds asked for; print each run and the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--recipe", default="race-pace")
    parser.add_argument("--compare-kinds", action="store_true",
                        help="run race-pace-discrete and race-pace-continuous instead")  # fmt: skip
    parser.add_argument("--tracks", nargs="+", default=list(LEAGUE_TRACKS))
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1])
    parser.add_argument("--minutes", type=float, default=30.0)
    parser.add_argument("--parallel", type=int, default=2, help="runs at once (each trains on one core)")
    parser.add_argument("--lr-schedule", help="override the recipe's learning-rate schedule")
    parser.add_argument("--json", help="also write the runs to this JSON file")
    args = parser.parse_args(argv)
    recipes = ["race-pace-discrete", "race-pace-continuous"] if args.compare_kinds else [args.recipe]
    jobs = [(rec, t, s) for t in args.tracks for s in args.seeds for rec in recipes]
    cores = len(os.sched_getaffinity(0))
    print(
        f"recipe pace: {', '.join(recipes)} on {', '.join(args.tracks)}, seeds {args.seeds}, "
        f"{args.minutes:g} min each; cores: {cores}, {args.parallel} at once, "
        f"load average at start: {os.getloadavg()[0]:.1f}",
        flush=True,
    )
    with concurrent.futures.ThreadPoolExecutor(max_workers=args.parallel) as pool:
        runs = list(pool.map(lambda job: run_recipe(*job, args), jobs))
    print(f"load average at the end: {os.getloadavg()[0]:.1f} (1 min), {os.getloadavg()[2]:.1f} (15 min)")
    print(table(runs))
    met = [
        bool(r.trials["best"].get("fastest") and r.theoretical_best
             and r.trials["best"]["fastest"] <= BEST_GOAL * r.theoretical_best
             and r.trials["last"].get("fastest")
             and r.trials["last"]["fastest"] <= LAST_GOAL * r.trials["best"]["fastest"]
             and not r.trials["best"].get("off_track") and not r.trials["last"].get("off_track"))
        for r in runs
    ]  # fmt: skip
    print(f"goals met (best <= {BEST_GOAL}x the limit, last <= {LAST_GOAL}x the best, 0 off-track): "
          f"{sum(met)}/{len(met)} runs")  # fmt: skip
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump([r.__dict__ for r in runs], f, indent=2)


if __name__ == "__main__":
    main()
