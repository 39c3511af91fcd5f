"""How faithfully does drx's car drive like DeepRacer's? Open-loop replay of the shared logs.

Each shared log set (``../shared/deepracer-logs``) is replayed with drx's car as fitted to its own
DeepRacer simulator version (deepracer-simapp 4 for the console's 2022 logs, 5 for
deepracer-for-cloud's 2023 logs; :data:`drx.sim.deepracer_logs.SIMULATOR_OF_SET`), and with the
default car (version 5) for comparison. Prints, for each set and for all of them together:

* the reference point's distance from the log after 15 steps (1 s) of open-loop replay from every
  logged pose (median and 90th percentile; also for commands >= 2.5 m/s and |steering| >= 20 deg),
  the heading error, and what extrapolating the last motion gives (:mod:`drx.sim.replay`);
* after a command was held 7 steps: the turning radius and the speed, logged against drx
  (:func:`drx.sim.replay.held_commands`), pooled over both log sets;

and checks them against issue 10's targets (position median <= 20 cm, p90 <= 45 cm, heading
median <= 10 deg; radius at +-30 deg within 15% at 1 and 2 m/s; speed within 5% at 1, 2 and 4 m/s).

    .venv/bin/python benchmarks/replay_fidelity.py [--logs ../shared/deepracer-logs] [--json]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from drx.sim.deepracer_logs import SIMULATOR_OF_SET, shared_log_sets  # noqa: E402
from drx.sim.dynamics import CarParams  # noqa: E402
from drx.sim.replay import ReplayResult, held_commands, replay  # noqa: E402

TARGETS = {"position_median_cm": 20.0, "position_p90_cm": 45.0, "heading_median_deg": 10.0}
RADIUS_TOLERANCE = 0.15
SPEED_TOLERANCE = 0.05


def combine(results: list[ReplayResult]) -> ReplayResult:
    """One result holding every window of ``results``."""
    cat = np.concatenate
    return ReplayResult(
        results[0].horizon,
        cat([r.position_error for r in results]), cat([r.heading_error for r in results]),
        cat([r.mean_speed_command for r in results]), cat([r.mean_abs_steering for r in results]),
        cat([r.baseline_error for r in results]),
    )  # fmt: skip


def line(label: str, st: dict) -> str:
    if not st.get("windows"):
        return f"  {label:22s} no windows"
    return (f"  {label:22s} {st['windows']:6d} windows  position median {st['position_median_cm']:5.1f} cm  "
            f"p90 {st['position_p90_cm']:5.1f} cm  heading median {st['heading_median_deg']:5.1f} deg  "
            f"(extrapolation {st['extrapolation_median_cm']:5.1f} cm)")  # fmt: skip


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--logs", type=Path, default=ROOT.parent / "shared" / "deepracer-logs")
    parser.add_argument("--horizon", type=int, default=15)
    parser.add_argument("--json", action="store_true", help="print one JSON document instead")
    args = parser.parse_args()
    if not args.logs.is_dir():
        print(f"no DeepRacer logs at {args.logs}; pass --logs", file=sys.stderr)
        return 2
    t0 = time.perf_counter()
    sets = shared_log_sets(args.logs)
    cars = {name: CarParams.for_simulator(SIMULATOR_OF_SET[name]) for name in sets}
    results = {name: replay(eps, cars[name], args.horizon) for name, eps in sets.items()}
    results["all"] = combine(list(results.values()))
    summaries = {name: r.summary() for name, r in results.items()}
    default = CarParams()
    default_car = {name: replay(eps, default, args.horizon, stride=2).summary()["overall"]
                   for name, eps in sets.items()}  # fmt: skip
    held = [h for name, eps in sets.items() for h in held_commands(eps, cars[name])]
    elapsed = time.perf_counter() - t0

    checks = []
    overall = summaries["all"]
    for group in ("overall", "fast_commands", "hard_steering"):
        for key, limit in TARGETS.items():
            value = overall[group].get(key)
            checks.append((f"{group} {key} <= {limit:g}", value, value is not None and value <= limit))
    figures = []
    for h in held:
        if abs(h.steering) == 30.0 and h.speed in (1.0, 2.0):
            ratio = h.drx_radius / h.log_radius
            figures.append({"figure": f"radius at {h.steering:+g} deg, {h.speed:g} m/s", "log": h.log_radius,
                            "drx": h.drx_radius, "ratio": ratio, "samples": h.samples})  # fmt: skip
            checks.append((f"radius at {h.steering:+g} deg {h.speed:g} m/s within 15%", round(ratio, 3),
                           abs(ratio - 1.0) <= RADIUS_TOLERANCE))  # fmt: skip
    for speed in (1.0, 2.0, 4.0):
        rows = [h for h in held if h.speed == speed]
        if not rows:
            continue
        n = np.array([h.samples for h in rows], dtype=float)
        log = float(np.sum(n * [h.log_speed for h in rows]) / n.sum())
        drx = float(np.sum(n * [h.drx_speed for h in rows]) / n.sum())
        figures.append({"figure": f"speed at {speed:g} m/s command", "log": log, "drx": drx,
                        "ratio": drx / log, "samples": int(n.sum())})  # fmt: skip
        checks.append((f"speed at {speed:g} m/s within 5% (log {log / speed:.3f}x command)",
                       round(drx / log, 3), abs(drx / log - 1.0) <= SPEED_TOLERANCE))  # fmt: skip

    if args.json:
        print(json.dumps({"replay": summaries, "default_car": default_car, "held_commands": figures,
                          "checks": [{"check": c, "value": v, "ok": ok} for c, v, ok in checks],
                          "seconds": round(elapsed, 1), "cores": os.cpu_count(),
                          "load": os.getloadavg()[0]}, indent=2))  # fmt: skip
        return 0
    print(f"Open-loop replay, {args.horizon} steps, drx's calibrated car "
          f"({os.cpu_count()} cores, load {os.getloadavg()[0]:.2f}, {elapsed:.1f} s)")  # fmt: skip
    for name, s in summaries.items():
        version = SIMULATOR_OF_SET.get(name)
        print(f"{name} (simulator {version} car):" if version else f"{name}:")
        print(line("all", s["overall"]))
        print(line("commands >= 2.5 m/s", s["fast_commands"]))
        print(line("|steering| >= 20 deg", s["hard_steering"]))
    print("every set with the default car (simulator 5), every other window:")
    for name, st in default_car.items():
        print(line(name, st))
    print("held commands (7 steps), log vs drx (each set with its simulator's car):")
    for f in figures:
        unit = "m" if f["figure"].startswith("radius") else "m/s"
        print(f"  {f['figure']:28s} log {f['log']:6.3f} {unit:3s} drx {f['drx']:6.3f} {unit:3s} "
              f"ratio {f['ratio']:.3f}  ({f['samples']} steps)")  # fmt: skip
    print("targets:")
    for c, v, ok in checks:
        print(f"  {'ok  ' if ok else 'MISS'} {c}: {v}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
