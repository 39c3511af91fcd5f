"""The DART referee's tables: where it can be trusted (version 5, against the logs) and how near drx's
version-6 car drives to it (version 6, which has no published log).

1. **Version 5's laws against version 5's logs**: every ``--stride``-th window of 15 steps of each shared
   version-5 log (deepracer-for-cloud 2022-2023, the console's 2025 runs), started where the log was,
   driven open-loop by simapp 5.3.3's car in DART under gazebo_ros_control's PID laws
   (``tools/dart_check``), and by drx's version-5 car from the same start; the reference point's
   distance from the log after 15 steps, median / p90 [cm], all windows and the slow (< 2.5 m/s mean
   command) and fast ones apart. Also how much more the referee turns than the log, and how much
   farther it drives (the medians of the windows' ratios).
2. **drx's version-6 car against the version-6 referee**: the windows of every shared log (their action
   sequences) that ``tools/fit_car_to_referee.py`` held out of its fit, driven by simapp 6.0.5's car in
   DART under gz_ros2_control's laws (mean over
   three 60 Hz control phases, :data:`drx.calibration.referee.V6_PHASES_MS`) and by drx's version-6 car,
   slow and fast apart; with the referee's own floor (one control phase against the mean), and drx's
   version-5 car against the same referee for scale.

    .venv/bin/python benchmarks/referee_fidelity.py [--stride 50] [--json]

Needs ``.venv-dart`` (``tools/dart_check/setup.sh``) and ``../shared/deepracer-logs`` and
``../shared/deepracer-car``; the referee's answers are cached under ``.cache/referee``.
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

from drx.calibration.logs import SIMULATOR_OF_SET  # noqa: E402
from drx.calibration.referee import (  # noqa: E402
    WindowBatch,
    distances,
    log_windows,
    logged_origins,
    referee_available,
    referee_log_sets,
    run_referee_phases,
)
from drx.calibration.replay import FAST_COMMAND  # noqa: E402
from drx.sim.dynamics import CarParams  # noqa: E402

DEFAULT_LOGS = ROOT.parent / "shared" / "deepracer-logs"
CACHE = ROOT / ".cache" / "referee"


def version_of(name: str) -> str:
    """The simulator version that recorded a referee log (the console's 2025 runs: simapp 5)."""
    return SIMULATOR_OF_SET.get(name, "5")


def cells(dist: np.ndarray, fast: np.ndarray) -> dict[str, list[float] | None]:
    """Median and p90 [cm] after the last step: all, slow, fast."""
    out: dict[str, list[float] | None] = {}
    for label, mask in (("all", np.ones_like(fast)), ("slow", ~fast), ("fast", fast)):
        d = dist[mask]
        out[label] = None if d.size == 0 else [round(100 * float(np.median(d)), 1),
                                                round(100 * float(np.percentile(d, 90)), 1)]  # fmt: skip
    return out


def text(c: dict[str, list[float] | None]) -> str:
    return "  ".join(f"{'-':>11}" if v is None else f"{v[0]:5.1f}/{v[1]:5.1f}" for v in c.values())


def turn_and_path(origins: np.ndarray, wins: list, log: np.ndarray) -> tuple[float, float]:
    """Medians over the windows of (turn / log's turn) where the log turned > 0.3 rad, and of (path
    length / log's)."""
    turn, path = [], []
    for o, w, g in zip(origins, wins, log, strict=True):
        start = np.array(w.pose)
        turned = _turned(start, g)
        if abs(turned) > 0.3:
            turn.append(_turned(start, o) / turned)
        path.append(_length(start, o) / max(_length(start, g), 1e-6))
    return round(float(np.median(turn)), 2), round(float(np.median(path)), 3)


def _length(start: np.ndarray, poses: np.ndarray) -> float:
    pts = np.vstack([start[None, :2], poses[:, :2]])
    return float(np.hypot(*np.diff(pts, axis=0).T).sum())


def _turned(start: np.ndarray, poses: np.ndarray) -> float:
    return float(np.unwrap(np.concatenate([[start[2]], poses[:, 2]]))[-1] - start[2])


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--logs", type=Path, default=DEFAULT_LOGS)
    parser.add_argument("--stride", type=int, default=50, help="every n-th window of each log [50]")
    parser.add_argument("--fit-stride", type=int, default=80,
                        help="the --stride tools/fit_car_to_referee.py fitted with [80]")  # fmt: skip
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    if args.stride < 1:
        print(f"--stride {args.stride} must be at least 1.")
        return 2
    why = referee_available()
    if why:
        print(f"The DART referee cannot run: {why}.")
        return 2
    sets = referee_log_sets(args.logs)
    if not sets:
        print(f"No DeepRacer logs under {args.logs}; point --logs at shared/deepracer-logs.")
        return 2
    started = time.perf_counter()
    print(f"{os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}; every {args.stride}th window, 15 steps")
    v5_car, v6_car = CarParams.for_simulator("5"), CarParams.for_simulator("6")
    result: dict = {"stride": args.stride, "version5": {}, "version6": {}}
    print("\n1. Version 5: the referee (simapp 5.3.3's car, PID laws) and drx's v5 car against the logs")
    print(f"{'log':34} {'windows':>7}  {'referee all / slow / fast cm':>37}"
          f"  {'drx v5 all / slow / fast cm':>37}"
          "  turn  path")  # fmt: skip
    for name, episodes in sets.items():
        if version_of(name) != "5":
            continue
        wins = log_windows(episodes, "5", stride=args.stride, name=name)
        ref, _ = run_referee_phases(wins, "5", cache=CACHE)
        log = logged_origins(wins)
        fast = np.array([w.mean_command >= FAST_COMMAND for w in wins])
        r = cells(distances(ref, log)[:, -1], fast)
        d = cells(distances(WindowBatch(wins).drive(v5_car), log)[:, -1], fast)
        turn, path = turn_and_path(ref, wins, log)
        result["version5"][name] = {"windows": len(wins), "referee": r, "drx": d, "turn": turn, "path": path}
        print(f"{name:34} {len(wins):7d}  {text(r)}  {text(d)}  {turn:4.2f}  {path:5.3f}")
    print("\n2. Version 6: drx's v6 car against the referee (simapp 6.0.5's car, gz_ros2_control laws),")
    print(f"   the windows tools/fit_car_to_referee.py held out (every {args.fit_stride}th, alternate)")
    print(f"{'log':34} {'windows':>7}  {'drx v6 all / slow / fast cm':>37}  {'floor: one phase':>37}"
          f"  {'drx v5 car':>11}")  # fmt: skip
    held, names = [], []
    for name, episodes in sets.items():  # as the fit splits them, so the referee's answers are shared
        wins = log_windows(episodes, "6", stride=args.fit_stride, name=name)[1::2]
        held += wins
        names += [name] * len(wins)
    target, runs = run_referee_phases(held, "6", cache=CACHE)
    batch = WindowBatch(held)
    fast = np.array([w.mean_command >= FAST_COMMAND for w in held])
    six = distances(batch.drive(v6_car), target)[:, -1]
    floor = distances(runs[0], target)[:, -1]
    five = distances(batch.drive(v5_car), target)[:, -1]
    logs = np.array(names)
    for name in [*sets, "all logs"]:
        mask = np.ones(len(held), bool) if name == "all logs" else logs == name
        row = {"windows": int(mask.sum()), "drx": cells(six[mask], fast[mask]),
               "floor": cells(floor[mask], fast[mask]),
               "drx_v5_car": cells(five[mask], fast[mask])["all"]}  # fmt: skip
        result["version6"][name] = row
        v5 = row["drx_v5_car"] or [0.0, 0.0]
        print(f"{name:34} {row['windows']:7d}  {text(row['drx'])}  {text(row['floor'])}  "
              f"{v5[0]:5.1f}/{v5[1]:5.1f}")  # fmt: skip
    result["seconds"] = round(time.perf_counter() - started, 1)
    print(f"\n{result['seconds']:.0f} s; load {os.getloadavg()[0]:.1f}")
    if args.json:
        print(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
