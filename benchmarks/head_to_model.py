"""Does training against a model matter? Train one model against an opponent and one alone, race both.

In one run, through the CLI as a user runs it, in a fresh data home, on the oval (counter-clockwise),
compact network, PPO, reward ``rewards/head_to_bot.py`` (with no car in ``params`` it is a lane and
speed reward, so both contenders train on the same reward):

1. ``rival``: ``drx model create`` + ``drx train --max-minutes R`` (a time trial): the opponent.
2. ``versus``: ``drx model clone rival versus --race-type head-to-model --opponent rival``, and
   ``alone``: ``drx model clone rival alone`` (a time trial), each ``drx train --max-minutes T``, both
   at once (the same minutes under the same load from the rest of the machine, one core each on two;
   ``--one-by-one`` trains them one after the other), from the same start: the rival's best checkpoint.
3. Each contender races the rival 20 times: ``drx race C rival --track oval --seed i`` (``i`` 0-19;
   the contender starts on the line, ``racecar_0``, for even seeds, behind the rival for odd ones),
   ``--laps 3 --time-cap-minutes 2``, DeepRacer's multi-car rules otherwise.

It prints the wins, collisions (and how many the contender was penalised for, as the car behind),
off-tracks, laps and lap times, the training steps and steps/s of each contender (the rollout with
one opponent costs an opponent's simulator step and network forward per step), and the env-only
rollout speed with the contender's own policy acting, alone and with one opponent.

Run: ``python benchmarks/head_to_model.py [--rival-minutes 4] [--minutes 4] [--races 20] [--one-by-one]
[--json FILE]``.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
REWARD = ROOT / "rewards" / "head_to_bot.py"
TRACK = "oval"


def drx(home: Path, *args: str, timeout: float = 3600) -> subprocess.CompletedProcess[str]:
    """``drx ARGS`` in the benchmark's data home; exits on failure."""
    env = {**os.environ, "DRX_HOME": str(home), "PYTHONPATH": str(ROOT), "DRX_TORCH_THREADS": "1"}
    done = subprocess.run([sys.executable, "-m", "drx.cli.main", *args], capture_output=True, text=True,
                          env=env, timeout=timeout)  # fmt: skip
    if done.returncode != 0:
        sys.exit(f"drx {' '.join(args)} failed ({done.returncode}):\n{done.stdout}\n{done.stderr}")
    return done


def train(home: Path, name: str, minutes: float) -> dict[str, Any]:
    """Train ``name`` for ``minutes``; its steps, wall time and steps/s."""
    t0 = time.monotonic()
    result = json.loads(
        drx(home, "train", name, "--max-minutes", f"{minutes:g}", "--seed", "0", "--json").stdout
    )
    wall = time.monotonic() - t0
    return {"steps": result["steps"], "episodes": result["episodes"], "wall": wall,
            "steps_per_s": result["steps"] / wall, "stop": result["stop_reason"]}  # fmt: skip


def race(home: Path, contender: str, seeds: range, laps: int, cap: float) -> list[dict[str, Any]]:
    """The contender's car in each race against the rival (its ``rival`` key: the rival's car)."""
    rows = []
    for seed in seeds:
        order = [contender, "rival"] if seed % 2 == 0 else ["rival", contender]
        rules = ("--laps", str(laps), "--time-cap-minutes", f"{cap:g}", "--seed", str(seed))
        out = json.loads(drx(home, "race", *order, "--track", TRACK, *rules, "--json").stdout)
        car = next(c for c in out["cars"] if c["name"] == contender)
        other = next(c for c in out["cars"] if c["name"] == "rival")
        rows.append({**car, "seed": seed, "ended": out["ended"], "rival": other})
    return rows


def rollout_speed(home: Path, name: str, with_opponent: bool, steps: int = 1500) -> float:
    """Env steps/s of ``name``'s training env with its own policy acting (no updates)."""
    code = f"""
import json, time, torch
torch.set_num_threads(1)
from drx.evaluate.head_to_model import load_opponents, with_opponents
from drx.evaluate.policy import ModelPolicy
from drx.services.checkpoints import choose_checkpoint
from drx.services.models import get_model
from drx.sim.env import DeepRacerEnv
from drx.sim.track import load_track
model = get_model({name!r})
opponents = load_opponents(model.race_config()) if {with_opponent!r} else []
env = with_opponents(lambda clock: DeepRacerEnv(track=load_track(model.track_name), vehicle=model.vehicle(),
                     mode="training", clock=clock), opponents)
policy = ModelPolicy(choose_checkpoint(model, "best").path, model.vehicle())
obs, _ = env.reset(seed=0)
t0 = time.process_time()
for _ in range({steps}):
    obs, _r, term, trunc, _i = env.step(policy(obs))
    if term or trunc:
        obs, _ = env.reset()
print(json.dumps({steps} / (time.process_time() - t0)))
"""
    env = {**os.environ, "DRX_HOME": str(home), "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=600)
    if done.returncode != 0:
        sys.exit(done.stderr)
    return float(json.loads(done.stdout.strip().splitlines()[-1]))


def summary(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Wins, collisions, lap times of a contender's races."""
    laps = [t for r in rows for t in r["lap_times"]]
    return {
        "races": len(rows),
        "wins": sum(r["place"] == 1 for r in rows),
        "finished": sum(r["status"] == "finished" for r in rows),
        "collisions": sum(r["collisions"] for r in rows),
        "penalised": sum(r["crashes"] for r in rows),
        "off_tracks": sum(r["off_tracks"] for r in rows),
        "laps": len(laps),
        "mean_lap": statistics.fmean(laps) if laps else None,
        "best_lap": min(laps) if laps else None,
        "mean_time": statistics.fmean([r["time"] for r in rows if r["time"] is not None] or [float("nan")]),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rival-minutes", type=float, default=4.0)
    ap.add_argument("--minutes", type=float, default=4.0)
    ap.add_argument("--races", type=int, default=20)
    ap.add_argument("--laps", type=int, default=3)
    ap.add_argument("--time-cap-minutes", type=float, default=2.0)
    ap.add_argument("--one-by-one", action="store_true", help="train the contenders one after the other")
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    t_start = time.monotonic()
    load0 = os.getloadavg()
    home = Path(tempfile.mkdtemp(prefix="drx-h2m-"))
    common = ("--network", "compact", "--reward", str(REWARD), "--track", TRACK)
    drx(home, "model", "create", "rival", *common)
    trained = {"rival": train(home, "rival", args.rival_minutes)}
    drx(home, "model", "clone", "rival", "versus", "--race-type", "head-to-model", "--opponent", "rival")
    drx(home, "model", "clone", "rival", "alone")
    if args.one_by_one:
        for name in ("versus", "alone"):
            trained[name] = train(home, name, args.minutes)
    else:
        with concurrent.futures.ThreadPoolExecutor(2) as pool:
            runs = {name: pool.submit(train, home, name, args.minutes) for name in ("versus", "alone")}
            trained |= {name: run.result() for name, run in runs.items()}
    speeds = {
        "alone": rollout_speed(home, "versus", False),
        "with_opponent": rollout_speed(home, "versus", True),
    }
    raced = {
        name: race(home, name, range(args.races), args.laps, args.time_cap_minutes)
        for name in ("versus", "alone")
    }
    results = {name: summary(rows) for name, rows in raced.items()}
    results |= {f"rival vs {name}": summary([r["rival"] for r in rows]) for name, rows in raced.items()}
    load1 = os.getloadavg()
    cores = os.cpu_count()
    print(f"\nhead-to-model benchmark: {TRACK}, compact PPO, reward {REWARD.name}; "
          f"rival {args.rival_minutes:g} min, "
          f"contenders {args.minutes:g} min each; {args.races} races x {args.laps} laps (cap "
          f"{args.time_cap_minutes:g} min) vs rival; {cores} cores, load {load0[0]:.2f} -> {load1[0]:.2f}, "
          f"{(time.monotonic() - t_start) / 60:.1f} min in all")  # fmt: skip
    head = (
        "| contender | trained steps | steps/s | wins | finished | collisions (penalised) | off-tracks "
        "| laps | mean lap | best lap |"
    )
    print(head)
    print("|" + "---|" * 10)
    for name in ("versus", "alone", "rival vs versus", "rival vs alone"):
        t, r = trained.get(name, trained["rival"]), results[name]
        fmt = lambda v: "-" if v is None else f"{v:.2f} s"  # noqa: E731
        cells = [name, t["steps"], f"{t['steps_per_s']:.0f}", f"{r['wins']}/{r['races']}", r["finished"],
                 f"{r['collisions']} ({r['penalised']})", r["off_tracks"], r["laps"], fmt(r["mean_lap"]),
                 fmt(r["best_lap"])]  # fmt: skip
        print("| " + " | ".join(str(c) for c in cells) + " |")
    print(f"rival: {trained['rival']['steps']} steps in {args.rival_minutes:g} min")
    alone, both = speeds["alone"], speeds["with_opponent"]
    print(f"rollout (env + own policy, CPU time): alone {alone:.0f} steps/s, with one opponent "
          f"{both:.0f} steps/s ({both / alone:.2f})")  # fmt: skip
    if args.json:
        args.json.write_text(json.dumps({"trained": trained, "results": results, "rollout": speeds,
                                         "cores": cores, "load": [load0, load1]}, indent=2))  # fmt: skip


if __name__ == "__main__":
    main()
