"""What ``drx watch`` costs: the jobs' pose files, and the watch server's drawing.

1. CPU time of a ``drx/DeepRacer-v0`` step on the oval with random actions, bare and wrapped in
   :class:`drx.watch.live.LivePoseWriter` with writing off (the per-step bookkeeping), repeats
   interleaved, medians; and the CPU time of one pose file (record, JSON, write, rename), which a
   job pays at most 15 times a second. Ratios of whole loops would drown these in the noise of a
   busy machine.
2. Milliseconds of CPU per frame pair the watch server draws (top-down 800 x 600 and camera
   640 x 480, both JPEG-encoded): :meth:`drx.watch.frames.Scenery.draw` at poses along the track.

    python benchmarks/watch_overhead.py            # ~1 minute
    python benchmarks/watch_overhead.py --quick    # a few seconds
"""

from __future__ import annotations

import argparse
import json
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
from drx.watch.live import PATH_STEPS, WRITE_HZ, LivePoseWriter  # noqa: E402


def us_per_step(env: object, steps: int, seed: int) -> float:
    """CPU microseconds per env step (random actions, resets included)."""
    rng = np.random.default_rng(seed)
    env.reset(seed=seed)  # type: ignore[attr-defined]
    cpu = time.process_time()
    for _ in range(steps):
        _, _, terminated, truncated, _ = env.step(np.int64(rng.integers(10)))  # type: ignore[attr-defined]
        if terminated or truncated:
            env.reset()  # type: ignore[attr-defined]
    return 1e6 * (time.process_time() - cpu) / steps


def us_per_write(env: LivePoseWriter, writes: int) -> float:
    """CPU microseconds of one pose file: the record, its JSON, the write and rename (synchronous here)."""
    _, info = env.reset(seed=0)
    for _ in range(PATH_STEPS):  # a full trail in the record
        _, _, _, _, info = env.step(np.int64(5))
    cpu = time.process_time()
    for _ in range(writes):
        env._file.put(json.dumps(env.pose(info, 0.0), separators=(",", ":")))
        env.flush()
    return 1e6 * (time.process_time() - cpu) / writes


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
    steps, repeats, frames, writes = (1000, 3, 60, 100) if args.quick else (4000, 7, 300, 1000)
    folder = Path(tempfile.mkdtemp(prefix="drx-watch-bench-"))
    bare_env = DeepRacerEnv(track="oval", mode="training")
    quiet_env = LivePoseWriter(DeepRacerEnv(track="oval", mode="training"), folder, "training", hz=1e-9)
    bare, quiet = [], []
    for k in range(repeats):  # interleaved, so that load changes hit both alike
        bare.append(us_per_step(bare_env, steps, k))
        quiet.append(us_per_step(quiet_env, steps, k))
    b, q = statistics.median(bare), statistics.median(quiet)
    w = us_per_write(quiet_env, writes)
    quiet_env.close()
    print(f"env step, CPU (oval, random actions, median of {repeats} x {steps}):")
    print(f"  bare                         {b:7.1f} us")
    print(f"  wrapped (bookkeeping only)   {q:7.1f} us   ({q - b:+.1f} us a step)")
    print(f"one pose file (record, JSON, write, rename; {writes} writes): {w:.0f} us CPU; "
          f"at {WRITE_HZ:.0f} a second: {100 * w * WRITE_HZ / 1e6:.2f}% of a core")  # fmt: skip
    print(f"watch server: {draw_ms(frames):.1f} ms CPU per frame pair (top-down + camera, JPEG), "
          f"{frames} frames")  # fmt: skip
    print(f"load: {os.getloadavg()[0]:.2f} (1-min average)")


if __name__ == "__main__":
    main()
