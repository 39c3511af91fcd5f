"""Why drx's version-6 car stops near 15 cm from the DART referee: the error's shape, another model
family fitted the same way, and the referee's own response to held commands.

On the windows ``tools/fit_car_to_referee.py`` fits and holds out (every ``--stride``-th window of every
shared log, alternate; the referee's answers come from its cache, ``.cache/referee``), it prints:

1. drx's version-6 car on the held-out windows: the distance after 15 steps split along and across the
   referee's heading, by mean commanded speed, and its growth step by step (median, cm);
2. a second model family fitted to the same windows the same way (scipy ``least_squares``, soft-L1,
   reference point after 5, 10 and 15 steps and the heading after 15): a dynamic bicycle with
   saturating tyre forces ``mu N tanh(C alpha / mu)`` per axle, a scrub yaw damping, the steering and
   speed laws of drx's car, in ``--substeps`` sub-steps per step; its held-out median / p90;
3. the referee held at one command from straight ahead for 2 s (simapp 6's and 5's laws): heading
   after 1 s, and turning radius over the last second, against drx's version-6 and version-5 cars.

    .venv/bin/python benchmarks/referee_model_families.py [--stride 80] [--substeps 6] [--evaluations 60]
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import numpy as np  # noqa: E402
from scipy.optimize import least_squares  # noqa: E402

from drx.calibration.fit import CHECK_STEPS, HEADING_WEIGHT  # noqa: E402
from drx.calibration.referee import (  # noqa: E402
    RefereeWindow,
    WindowBatch,
    drive_car,
    log_windows,
    referee_available,
    referee_log_sets,
    reference_points,
    run_referee,
    run_referee_phases,
    step_lengths_ms,
)
from drx.calibration.referee_fit import summary_cm  # noqa: E402
from drx.sim.dynamics import CarParams  # noqa: E402

CACHE = ROOT / ".cache" / "referee"
LOGS = ROOT.parent / "shared" / "deepracer-logs"
G, L = 9.81, 0.164
# name: (start, lower, upper)
BICYCLE = {
    "delay": (0.25, 0.0, 1.5), "tau_s": (0.16, 0.05, 0.4), "gain": (0.8, 0.2, 1.5), "Cf": (8.0, 0.5, 60.0),
    "Cr": (12.0, 0.5, 60.0), "muf": (0.6, 0.1, 2.0), "mur": (0.6, 0.1, 2.0), "scrub": (0.5, 0.0, 20.0),
    "iz": (0.0129, 0.003, 0.05), "front_share": (0.43, 0.2, 0.8), "speed_gain": (0.97, 0.8, 1.2),
    "speed_offset": (0.05, -0.2, 0.3), "tau_v": (0.05, 0.005, 0.5), "tau_vv": (0.03, 0.0, 0.3),
    "amax": (6.0, 1.0, 20.0), "bmax": (8.0, 1.0, 30.0),
}  # fmt: skip


def bicycle(p: np.ndarray, batch: WindowBatch, substeps: int) -> np.ndarray:
    """``(windows, steps, 3)`` origin poses of the dynamic bicycle with constants ``p`` (see BICYCLE)."""
    delay, tau_s, gain, cf, cr, muf, mur, scrub, iz, share, sg, so, tv, tvv, amax, bmax = p
    a = share * L  # centre of mass behind the front axle
    b = L - a
    off = L / 2 - a  # the centre of mass ahead of the origin
    yaw = batch.pose[:, 2].copy()
    x = batch.pose[:, 0] + off * np.cos(yaw)
    y = batch.pose[:, 1] + off * np.sin(yaw)
    v = batch.speed.copy()
    r = v * batch.bend
    vy = np.zeros_like(v)
    delta = batch.steering.copy()
    nd, f = int(math.floor(delay)), delay - math.floor(delay)
    hist = [batch.prior] * 3
    out = np.empty((len(v), batch.commands.shape[1], 3))
    nf, nr = G * b / L, G * a / L  # axle loads per unit mass
    for i in range(batch.commands.shape[1]):
        hist = [*hist[1:], batch.commands[:, i]]
        new = hist[-1 - nd]
        old = hist[-2 - nd] if f > 0 else new
        for cmd, frac in ((old, f), (new, 1.0 - f)):
            if frac <= 0:
                continue
            h = frac * batch.dt[:, i] / substeps
            target = np.where(cmd[:, 0] > 0, sg * np.minimum(cmd[:, 0], 3.5) + so, 0.0)
            for _ in range(substeps):
                delta = cmd[:, 1] + (delta - cmd[:, 1]) * np.exp(-h / tau_s)
                dv = np.clip((target - v) * (1 - np.exp(-h / (tv + tvv * np.abs(v)))), -bmax * h, amax * h)
                vx = np.maximum(v, 0.05)
                steer = gain * delta
                front = muf * nf * np.tanh(cf * (steer - np.arctan2(vy + a * r, vx)) / muf)
                rear = mur * nr * np.tanh(cr * (-np.arctan2(vy - b * r, vx)) / mur)
                vy = vy + h * (front * np.cos(steer) + rear - vx * r)
                r = r + h * ((a * front * np.cos(steer) - b * rear) / iz - scrub * r)
                v = v + dv
                mid = yaw + 0.5 * h * r
                x = x + h * (v * np.cos(mid) - vy * np.sin(mid))
                y = y + h * (v * np.sin(mid) + vy * np.cos(mid))
                yaw = yaw + h * r
        out[:, i] = np.column_stack([x - off * np.cos(yaw), y - off * np.sin(yaw), yaw])
    return out


def residuals(driven: np.ndarray, target: np.ndarray) -> np.ndarray:
    d = (reference_points(driven) - reference_points(target))[:, list(CHECK_STEPS), :]
    heading = np.angle(np.exp(1j * (driven[:, -1, 2] - target[:, -1, 2])))
    return np.concatenate([d.reshape(len(d), -1), HEADING_WEIGHT * heading[:, None]], 1).ravel()


def held(speed: float, steer_deg: float, steps: int = 30) -> RefereeWindow:
    cmd = (speed, math.radians(steer_deg))
    return RefereeWindow((0.0, 0.0, 0.0), speed * 1.029, 0.0, 0.0, (cmd,) * steps,
                         step_lengths_ms(1 / 15, steps), cmd)  # fmt: skip


def radius(poses: np.ndarray) -> float:
    seg = poses[-16:]
    turned = abs(float(np.unwrap(seg[:, 2])[-1] - np.unwrap(seg[:, 2])[0]))
    return float(np.hypot(*np.diff(seg[:, :2], axis=0).T).sum()) / max(turned, 1e-9)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--stride", type=int, default=80)
    parser.add_argument("--substeps", type=int, default=6)
    parser.add_argument("--evaluations", type=int, default=60)
    args = parser.parse_args()
    if args.stride < 2 or args.substeps < 1 or args.evaluations < 1:
        print("--stride must be at least 2, --substeps and --evaluations at least 1.")
        return 2
    why = referee_available()
    if why:
        print(f"The DART referee cannot run: {why}.")
        return 2
    print(f"{os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}")
    fit_wins: list[RefereeWindow] = []
    held_out: list[RefereeWindow] = []
    for episodes in referee_log_sets(LOGS).values():
        wins = log_windows(episodes, "6", stride=args.stride)
        fit_wins += wins[0::2]
        held_out += wins[1::2]
    fit_target, _ = run_referee_phases(fit_wins, "6", cache=CACHE)
    target, _ = run_referee_phases(held_out, "6", cache=CACHE)
    batch = WindowBatch(held_out)
    six = batch.drive(CarParams.for_simulator("6"))
    diff = reference_points(six[:, -1]) - reference_points(target[:, -1])
    heading = target[:, -1, 2]
    along = np.abs(diff[:, 0] * np.cos(heading) + diff[:, 1] * np.sin(heading))
    across = np.abs(-diff[:, 0] * np.sin(heading) + diff[:, 1] * np.cos(heading))
    print(f"\n1. drx's v6 car, {len(held_out)} held-out windows: {summary_cm(six, target)} cm; median "
          f"along {100 * np.median(along):.1f} cm, across {100 * np.median(across):.1f} cm")  # fmt: skip
    speed = np.array([w.mean_command for w in held_out])
    dist = np.hypot(along, across)
    for lo, hi in ((0.0, 1.5), (1.5, 2.5), (2.5, 5.0)):
        m = (speed >= lo) & (speed < hi)
        median = 100 * np.median(dist[m])
        print(f"   mean command {lo:g}-{hi:g} m/s: {int(m.sum())} windows, median {median:.1f} cm")
    steps = np.hypot(*(reference_points(six) - reference_points(target)).transpose(2, 0, 1))
    print("   median by step, cm:", " ".join(f"{100 * x:.1f}" for x in np.median(steps, axis=0)))
    names = list(BICYCLE)
    x0 = np.array([BICYCLE[n][0] for n in names])
    bounds = (np.array([BICYCLE[n][1] for n in names]), np.array([BICYCLE[n][2] for n in names]))
    fit_batch = WindowBatch(fit_wins)
    started = time.perf_counter()
    result = least_squares(lambda p: residuals(bicycle(p, fit_batch, args.substeps), fit_target), x0,
                           bounds=bounds, loss="soft_l1", f_scale=0.05, max_nfev=args.evaluations,
                           x_scale="jac")  # fmt: skip
    print(f"\n2. dynamic bicycle ({len(names)} constants, {args.substeps} sub-steps), fitted in "
          f"{time.perf_counter() - started:.0f} s ({result.nfev} evaluations): held out "
          f"{summary_cm(bicycle(result.x, batch, args.substeps), target)} cm")  # fmt: skip
    print("   " + ", ".join(f"{n} {v:.4g}" for n, v in zip(names, result.x, strict=True)))
    print("\n3. held from straight ahead: heading after 1 s [rad], radius over the 2nd second [m]")
    commands = [(v, s) for v in (1.0, 2.0, 3.0) for s in (5.0, -5.0, 30.0)]
    wins = [held(v, s) for v, s in commands]
    referee = {ver: run_referee(wins, ver, cache=CACHE) for ver in ("6", "5")}
    cars = {ver: CarParams.for_simulator(ver) for ver in ("6", "5")}
    print(f"   {'command':14} {'referee v6':>18} {'referee v5':>18} {'drx v6':>18} {'drx v5':>18}")
    for i, (v, s) in enumerate(commands):
        cells = [referee["6"][i], referee["5"][i], *(drive_car(wins[i], cars[ver]) for ver in ("6", "5"))]
        text = "  ".join(f"{p[14, 2]:+7.3f} / {radius(p):6.2f}" for p in cells)
        print(f"   {v:.0f} m/s {s:+5.0f} deg  {text}")
    print(f"\nload {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
