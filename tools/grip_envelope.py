"""The grip envelope of DeepRacer's car against drx's: the lateral acceleration held at speed, per log.

For each DeepRacer log given (robomaker logs or sim-trace CSVs, any layout :mod:`drx.calibration.logs`
reads; by default the fast simapp 5 logs under ``../shared/deepracer-logs``: deepracer-for-cloud's
2022_june_pro run and the console's 2025 runs) it prints, per band of logged speed, the 50th, 90th and
99th percentiles of the lateral acceleration ``v^2 * curvature`` the car's origin shows in the log and
in drx's car replaying the same steps (:mod:`drx.calibration.grip`), beside drx's full-lock limit at the
band's middle; then the steady turns alone, and the same per band of wheel slip (does the grip fall as
the wheels slip?); and the radius of the turns held near full lock (27 deg or more, one side, 7 steps)
at 1-2.5 m/s, logged. Pooled over the logs at the end.

    .venv/bin/python tools/grip_envelope.py [LOG ...] [--simulator 5] [--stride N]
"""

from __future__ import annotations

import argparse
import glob
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from drx.calibration.grip import GripSamples, envelope, grip_samples, lock_radius  # noqa: E402
from drx.calibration.logs import read_traces  # noqa: E402
from drx.errors import DrxError  # noqa: E402
from drx.sim.dynamics import CarParams  # noqa: E402

SHARED_LOGS = ROOT.parent / "shared" / "deepracer-logs"
# The fast simapp 5 logs (shared/deepracer-logs/README.md): 1.3-4 m/s discrete, and the console's last
# weeks, continuous to 3.5-4 m/s.
FAST_LOGS = (
    "drfc-2022-june-pro/*_robomaker.*.log",
    "console-2025-10-continuous/*/*robomaker.log",
    "console-2025-10-continuous/*/*robomaker.txt",
)


def fmt(values: tuple[float, ...]) -> str:
    return " ".join(f"{v:4.2f}" for v in values)


def table(title: str, rows: list, show_limit: bool) -> None:
    print(f"  {title}")
    for r in rows:
        limit = f"  drx limit {r.limit:4.2f}" if show_limit and r.limit is not None else ""
        print(f"    {r.band:14s} {r.samples:6d}  log p50/p90/p99 {fmt(r.log)}  drx {fmt(r.drx)}{limit}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("logs", nargs="*", type=Path, help="DeepRacer logs [the fast simapp 5 logs]")
    parser.add_argument("--simulator", default="5", choices=("4", "5"), help="drx's car of this version [5]")
    parser.add_argument("--stride", type=int, default=1, help="every n-th sample")
    args = parser.parse_args()
    if args.stride < 1:
        print(f"--stride {args.stride} is below 1; give 1 or more.", file=sys.stderr)
        return 2
    t0 = time.perf_counter()
    paths = args.logs or sorted(Path(p) for g in FAST_LOGS for p in glob.glob(str(SHARED_LOGS / g)))
    if not paths:
        print(f"no logs given and none under {SHARED_LOGS}; give DeepRacer logs.", file=sys.stderr)
        return 2
    car = CarParams.for_simulator(args.simulator)
    print(f"grip envelope, |lateral acceleration| [m/s^2] at >= 1.5 m/s, simulator {args.simulator}'s car "
          f"({os.cpu_count()} cores, load {os.getloadavg()[0]:.2f})")  # fmt: skip
    pooled: list[GripSamples] = []
    for path in paths:
        try:
            episodes = read_traces([path])
        except DrxError as err:
            print(str(err), file=sys.stderr)
            return 2
        s = grip_samples(episodes, car, stride=args.stride)
        pooled.append(s)
        print(f"{path}: {len(s)} samples, {int(s.steady.sum())} steady")
        table("by speed, every sample:", envelope(s, car), True)
        table("by speed, steady turns:", envelope(s, car, steady_only=True), False)
        table("by wheel slip, every sample:", envelope(s, by="slip"), False)
        radii = lock_radius(episodes)
        held = "  ".join(f"{v:g} m/s {r:.2f} m ({n})" for v, (r, n) in radii.items()) or "none"
        print(f"  turns held at >= 27 deg for 7 steps, logged radius (steps): {held}")
    s = GripSamples.join(pooled)
    print(f"all {len(paths)} logs: {len(s)} samples")
    table("by speed, every sample:", envelope(s, car), True)
    table("by speed, steady turns:", envelope(s, car, steady_only=True), False)
    table("by wheel slip, every sample:", envelope(s, by="slip"), False)
    print(f"({time.perf_counter() - t0:.0f} s, load {os.getloadavg()[0]:.2f})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
