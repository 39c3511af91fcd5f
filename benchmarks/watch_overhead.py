"""What ``drx watch`` costs: the jobs' pose files, and the watch server's drawing.

1. Env steps per CPU-second and per second of ``drx/DeepRacer-v0`` on the oval with random
   actions, bare and wrapped in :class:`drx.watch.live.LivePoseWriter` (at its 20 writes per
   second), repeats interleaved, medians; CPU time matters less to other work on the machine.
2. Milliseconds of CPU per frame pair the watch server draws (top-down 800 x 600 and camera
   640 x 480, both JPEG-encoded): :meth:`drx.watch.frames.Scenery.draw` at poses along the track.

    python benchmarks/watch_overhead.py            # ~1 minute
    python benchmarks/watch_overhead.py --quick    # a few seconds
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from drx.sim.env import DeepRacerEnv  # noqa: E402
from drx.watch.live import LivePoseWriter  # noqa: E402


def steps_per_second(env: object, steps: int, seed: int) -> tuple[float, float]:
    """(steps per CPU-second of the process, its writer thread included; steps per wall-second)."""
    rng = np.random.default_rng(seed)
    env.reset(seed=seed)  # type: ignore[attr-defined]
    cpu, wall = time.process_time(), time.perf_counter()
    for _ in range(steps):
        _, _, terminated, truncated, _ = env.step(np.int64(rng.integers(10)))  # type: ignore[attr-defined]
        if terminated or truncated:
            env.reset()  # type: ignore[attr-defined]
    return steps / max(time.process_time() - cpu, 1e-9), steps / max(time.perf_counter() - wall, 1e-9)


def draw_ms(frames: int) -> float:
    from drx.sim.track import load_track
    from drx.watch.frames import Scenery

    scenery = Scenery("oval")
    track = load_track("oval")
    s = np.linspace(0, track.length, frames, endpoint=False)
    pts = np.asarray(track.point_at(s), float)
    yaws = np.asarray(track.heading_at(s), float).reshape(-1)
    trail: list[tuple[float, float]] = []
    scenery.draw({"x": pts[0, 0], "y": pts[0, 1], "yaw": yaws[0]}, trail)  # warm-up
    start = time.process_time()
    for (x, y), yaw in zip(pts, yaws, strict=True):
        trail.append((float(x), float(y)))
        scenery.draw({"x": x, "y": y, "yaw": yaw}, trail)
    return 1000.0 * (time.process_time() - start) / frames


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a few seconds instead of about a minute")
    args = parser.parse_args()
    cv2.setNumThreads(1)
    steps, repeats, frames = (1000, 3, 60) if args.quick else (4000, 5, 300)
    folder = Path(tempfile.mkdtemp(prefix="drx-watch-bench-"))
    bare_env = DeepRacerEnv(track="oval", mode="training")
    live_env = LivePoseWriter(DeepRacerEnv(track="oval", mode="training"), folder, "training")
    bare, live = [], []
    for k in range(repeats):
        bare.append(steps_per_second(bare_env, steps, k))
        live.append(steps_per_second(live_env, steps, k))
    live_env.close()
    print(f"env steps/s (oval, random actions, median of {repeats} x {steps}):   per CPU-second   per second")
    b = [statistics.median(r[i] for r in bare) for i in (0, 1)]
    w = [statistics.median(r[i] for r in live) for i in (0, 1)]
    print(f"  bare                 {b[0]:8.0f}             {b[1]:8.0f}")
    print(f"  with pose files      {w[0]:8.0f} ({100 * (w[0] / b[0] - 1):+.1f}%)    "
          f"{w[1]:8.0f} ({100 * (w[1] / b[1] - 1):+.1f}%)")  # fmt: skip
    print(f"watch server: {draw_ms(frames):.1f} ms CPU per frame pair (top-down + camera, JPEG), "
          f"{frames} frames")  # fmt: skip
    print(f"load: {os.getloadavg()[0]:.2f} (1-min average)")


if __name__ == "__main__":
    main()
