"""Fit drx's version-6 car to the DART referee and write it into ``drx/sim/car_calibration.py``.

Simulator 6 (DeepRacer on AWS, deepracer-for-cloud 6.x) has no published log, so its car is fitted to
the referee (:mod:`drx.calibration.referee_fit`): windows of 15 steps of the shared logs' own action
sequences (every ``--stride``-th window of every log, ``../shared/deepracer-logs``), started where the
log was, are driven by simapp 6.0.5's car in DART under version 6's controller laws
(``tools/dart_check/``, mean over the controllers' phases), and drx's car is fitted to end where
the referee's did. Alternate windows are held out of the fit and reported apart, per log and for
the fast (mean command >= 2.5 m/s) and slow windows. The referee's answers are cached under
``--cache`` (keyed by the windows and the referee's code).

Usage (from the repository root, with ``shared/`` beside it and ``tools/dart_check/setup.sh`` run);
the committed calibration::

    .venv/bin/python tools/fit_car_to_referee.py --stride 80 --max-evaluations 60
    .venv/bin/python tools/fit_car_to_referee.py --dry-run          # fit and print only
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402

from drx.calibration.calibration_module import write_module  # noqa: E402
from drx.calibration.fit import step_time_figures  # noqa: E402
from drx.calibration.referee import (  # noqa: E402
    REFEREE_LOGS,
    WindowBatch,
    log_windows,
    referee_available,
    referee_log_sets,
    run_referee_phases,
)
from drx.calibration.referee_fit import fit_to_referee, summary_cm  # noqa: E402
from drx.calibration.replay import FAST_COMMAND  # noqa: E402
from drx.sim.dynamics import CarParams  # noqa: E402

DEFAULT_LOGS = ROOT.parent / "shared" / "deepracer-logs"
DEFAULT_CACHE = ROOT / ".cache" / "referee"
VERSION = "6"
# The step's timing: simapp 6 keeps simapp 5's 15 Hz pause-act-wait loop (deepracer_racetrack_env.py),
# and no version-6 log shows its jitter, so the version-5 logs' mean step and jitter stand in.
TIMING_LOGS = ("drfc-4workers", "drfc-june-pro")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--logs", type=Path, default=DEFAULT_LOGS, help="shared/deepracer-logs folder")
    parser.add_argument("--stride", type=int, default=80, help="use every n-th window of each log [80]")
    parser.add_argument("--max-evaluations", type=int, default=60, help="least_squares' max_nfev [60]")
    parser.add_argument(
        "--cache", type=Path, default=DEFAULT_CACHE, help="where the referee's answers are kept"
    )
    parser.add_argument("--dry-run", action="store_true", help="fit and print; write nothing")
    args = parser.parse_args()
    if args.stride < 2:
        print(f"--stride {args.stride} must be at least 2 (alternate windows are held out).")
        return 2
    why = referee_available()
    if why:
        print(f"The DART referee cannot run: {why}.")
        return 2
    sets = referee_log_sets(args.logs)
    if not sets:
        print(f"No DeepRacer logs under {args.logs}; point --logs at shared/deepracer-logs.")
        return 2
    fit_wins, check_wins, check_log = [], [], []
    for name, episodes in sets.items():
        wins = log_windows(episodes, VERSION, stride=args.stride, name=name)
        fit_wins += wins[0::2]
        check_wins += wins[1::2]
        check_log += [name] * len(wins[1::2])
    print(f"{len(fit_wins)} windows to fit, {len(check_wins)} held out, from {len(sets)} logs; "
          "running the referee (3 control phases each)...", flush=True)  # fmt: skip
    fit_target, _ = run_referee_phases(fit_wins, VERSION, cache=args.cache)
    check_target, check_runs = run_referee_phases(check_wins, VERSION, cache=args.cache)
    start = CarParams.for_simulator("5")
    fit = fit_to_referee(fit_wins, fit_target, start, max_evaluations=args.max_evaluations, verbose=1)
    timing = [eps for name, eps in sets.items() if name in TIMING_LOGS]
    step_time, jitter = step_time_figures([ep for eps in timing for ep in eps])
    car = fit.car.with_values(step_time=step_time, step_time_jitter=jitter)
    print(f"fit: {fit.evaluations} evaluations in {fit.seconds:.0f} s; fitted windows {fit.before_cm} -> "
          f"{fit.after_cm} cm (median, p90 after 15 steps)")  # fmt: skip
    driven = WindowBatch(check_wins).drive(car)
    fast = np.array([w.mean_command >= FAST_COMMAND for w in check_wins])
    logs = np.array(check_log)
    report = []
    rows = [("all held-out windows", np.ones(len(check_wins), bool))] + [
        (name, logs == name) for name in REFEREE_LOGS if name in sets
    ]
    print(f"{'held out':36} {'windows':>7} {'all cm':>12} {'slow cm':>12} {'fast cm':>12} {'floor cm':>12}")
    for label, mask in rows:
        parts = [_cell(driven, check_target, mask & m) for m in (np.ones_like(mask), ~fast, fast)]
        floor = _cell(check_runs[0], check_target, mask)
        print(f"{label:36} {int(mask.sum()):7d} {parts[0]:>12} {parts[1]:>12} {parts[2]:>12} {floor:>12}")
        report.append(
            f"{label}: {int(mask.sum())} windows, after 15 steps median / p90 {parts[0]} cm "
            f"(slow {parts[1]}, fast {parts[2]}; one control phase against the mean {floor})"
        )
    for name in fit.names:
        print(f"  {name} = {getattr(car, name):.6g}")
    if args.dry_run:
        return 0
    data = (f"the DART referee (tools/dart_check, simapp 6.0.5's car and version 6's controller laws, mean "
            f"of {len(sets)} logs' windows over 3 control phases; {len(fit_wins)} windows fitted, "
            f"--stride {args.stride})")  # fmt: skip
    command = " ".join(["tools/fit_car_to_referee.py", *sys.argv[1:]])
    write_module(VERSION, car, {}, report, {}, command=command, data=data)
    print("wrote drx/sim/car_calibration.py")
    return 0


def _cell(driven: np.ndarray, target: np.ndarray, mask: np.ndarray) -> str:
    if not mask.any():
        return "-"
    median, p90 = summary_cm(driven[mask], target[mask])
    return f"{median:.1f}/{p90:.1f}"


if __name__ == "__main__":
    sys.exit(main())
