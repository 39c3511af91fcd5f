"""How faithfully does drx's car drive like DeepRacer's? Open-loop replay of the shared logs.

Each shared log set (``../shared/deepracer-logs``) is replayed with drx's car as fitted to its own
DeepRacer simulator version (deepracer-simapp 4 for the console's 2022 logs, 5 for
deepracer-for-cloud's 2023 logs; :data:`drx.calibration.logs.SIMULATOR_OF_SET`), and with the
default car (version 5) for comparison. Prints, for each set and for all of them together:

* the reference point's distance from the log after 15 steps (1 s) of open-loop replay from every
  logged pose (median and 90th percentile; also for commands >= 2.5 m/s and |steering| >= 20 deg),
  the heading error, and what extrapolating the last motion gives (:mod:`drx.calibration.replay`);
* after a command was held 7 steps: the turning radius and the speed, logged against drx
  (:func:`drx.calibration.replay.held_commands`), pooled over both log sets;
* the deceleration after a >= 3.5 m/s command drops to <= 1 m/s for 8 steps, logged against drx
  (:func:`drx.calibration.replay.hard_braking`; simapp 5's logs, the console's never brake from that fast);

the same for each log replayed with its simulator's car fitted *without* it (the held-out cars
``tools/fit_car_model.py`` writes: how the car does on logs it was not fitted to); and checks them
against issue 10's targets (:mod:`drx.calibration.fidelity`; position median <= 20 cm,
p90 <= 45 cm, heading median <= 10 deg; radius at +-30 deg within 15% at 1 and 2 m/s; speed within
5% at 1, 2 and 4 m/s; and the braking within 10%) and issue 25's held-out targets (each log: median
<= 15 cm, p90 <= 40 cm, commands >= 2.5 m/s median <= 25 cm).

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

from drx.calibration.fidelity import (  # noqa: E402
    POOLED_LOGS,
    checks,
    held_figures,
    held_out,
    held_out_checks,
    measure,
)
from drx.calibration.logs import SIMULATOR_OF_SET  # noqa: E402
from drx.calibration.replay import replay  # noqa: E402
from drx.sim.dynamics import CarParams  # noqa: E402


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
    measurement = measure(args.logs, args.horizon)
    summaries = {name: r.summary() for name, r in measurement.results.items()}
    default = CarParams()
    default_car = {name: replay(eps, default, args.horizon, stride=2).summary()["overall"]
                   for name, eps in measurement.episodes.items()}  # fmt: skip
    figures = held_figures(measurement.held, measurement.held_speeds)
    held = held_out(measurement, args.horizon)
    elapsed = time.perf_counter() - t0
    results = checks(measurement) + held_out_checks(held)

    if args.json:
        braking = {name: vars(b) for name, b in measurement.braking.items()}
        held_json = {h.log: {"simulator": h.simulator, "replay": h.summary} for h in held}
        print(json.dumps({"replay": summaries, "default_car": default_car, "held_commands": figures,
                          "held_out": held_json,
                          "braking": braking,
                          "checks": [{"check": c.name, "value": c.value, "ok": c.ok} for c in results],
                          "seconds": round(elapsed, 1), "cores": os.cpu_count(),
                          "load": os.getloadavg()[0]}, indent=2))  # fmt: skip
        return 0
    print(f"Open-loop replay, {args.horizon} steps, drx's calibrated car "
          f"({os.cpu_count()} cores, load {os.getloadavg()[0]:.2f}, {elapsed:.1f} s)")  # fmt: skip
    for name, s in summaries.items():
        version = SIMULATOR_OF_SET.get(name)
        label = f"all of {', '.join(POOLED_LOGS)} (issue 10's logs), pooled:"
        print(f"{name} (simulator {version} car):" if version else label)
        print(line("all", s["overall"]))
        print(line("commands >= 2.5 m/s", s["fast_commands"]))
        print(line("|steering| >= 20 deg", s["hard_steering"]))
    print("held out: each log with its simulator's car fitted without it (tools/fit_car_model.py):")
    for h in held:
        if h.summary is None:
            print(f"  {h.log} (simulator {h.simulator}): no car fitted without it")
            continue
        print(f"{h.log} (simulator {h.simulator} car, fitted on the other logs):")
        print(line("all", h.summary["overall"]))
        print(line("commands >= 2.5 m/s", h.summary["fast_commands"]))
    print("every set with the default car (simulator 5), every other window:")
    for name, st in default_car.items():
        print(line(name, st))
    print("held commands (7 steps), log vs drx (each set with its simulator's car):")
    for f in figures:
        unit = "m" if f["figure"].startswith("radius") else "m/s"
        print(f"  {f['figure']:28s} log {f['log']:6.3f} {unit:3s} drx {f['drx']:6.3f} {unit:3s} "
              f"ratio {f['ratio']:.3f}  ({f['samples']} steps)")  # fmt: skip
    print("braking from a >= 3.5 m/s command to <= 1 m/s held 8 steps, log vs drx (medians):")
    for name, b in measurement.braking.items():
        print(f"  {name:22s} log {b.log_deceleration:5.2f} m/s^2  drx {b.drx_deceleration:5.2f} m/s^2  "
              f"ratio {b.drx_deceleration / b.log_deceleration:.3f}  ({b.samples} stretches)")  # fmt: skip
    print("targets:")
    for c in results:
        print(f"  {'ok  ' if c.ok else 'MISS'} {c.name}: {c.value}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
