"""Environment steps per second on one core: drx/DeepRacer-v0 vs highway-env's racetrack-v0.

Both loops: random actions, a 160x120 grayscale camera-like observation, one
frame per step at 15 Hz, resets on episode end, the whole Gymnasium stack
(``gymnasium.make`` wrappers included). drx uses the sample centre-line reward
(``rewards/follow_center_line.py``) on ``reinvent_base`` from ``../shared/tracks``
(else a project track). highway-env's racetrack gets ``GrayscaleObservation``
(160x120, one frame, DeepRacer's grey weights), ``policy_frequency`` 15 so a step
is one 1/15 s frame as in drx, and no other vehicles (drx has none either).

Everything is limited to one thread (OMP/MKL/OpenBLAS, ``cv2.setNumThreads(1)``,
``torch.set_num_threads(1)``) and the process is pinned to one CPU. Figures are
medians of several repeats.

    python benchmarks/sim_throughput.py            # full run
    python benchmarks/sim_throughput.py --quick    # a few seconds
    python benchmarks/sim_throughput.py --profile  # cProfile of the drx loop
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS", "NUMEXPR_NUM_THREADS"):
    os.environ[_var] = "1"
os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")

import argparse  # noqa: E402
import json  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import cv2  # noqa: E402
import gymnasium as gym  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SHARED_TRACK = ROOT.parent / "shared" / "tracks" / "reinvent_base.npy"
REWARD = ROOT / "rewards" / "follow_center_line.py"


def limit_threads() -> str:
    """One thread everywhere, pinned to one CPU; returns a description."""
    cv2.setNumThreads(1)
    try:
        import torch

        torch.set_num_threads(1)
    except ImportError:
        pass
    pinned = ""
    if hasattr(os, "sched_setaffinity"):
        cpu = min(os.sched_getaffinity(0))
        os.sched_setaffinity(0, {cpu})
        pinned = f", pinned to CPU {cpu}"
    return f"1 thread{pinned} (machine: {os.cpu_count()} cores)"


def make_drx() -> tuple[gym.Env, str]:
    """drx's env on reinvent_base with the sample centre-line reward."""
    import drx  # noqa: F401  (registers the env)

    track: Any = str(SHARED_TRACK) if SHARED_TRACK.is_file() else "oval"
    reward: Any = str(REWARD) if REWARD.is_file() else None
    env = gym.make("drx/DeepRacer-v0", track=track, reward_function=reward)
    label = f"track {Path(str(track)).stem}, reward {Path(reward).name if reward else 'built-in centre line'}"
    return env, label


def make_highway() -> tuple[gym.Env, str]:
    """highway-env's racetrack-v0 with a 160x120 grayscale image observation."""
    import highway_env  # noqa: F401  (registers its envs)

    config = {
        "observation": {
            "type": "GrayscaleObservation",
            "observation_shape": (160, 120),
            "stack_size": 1,
            "weights": [0.2989, 0.5870, 0.1140],
        },
        "policy_frequency": 15,
        "other_vehicles": 0,
    }
    env = gym.make("racetrack-v0", config=config)
    return env, "racetrack-v0, GrayscaleObservation 160x120, policy 15 Hz, no other vehicles"


def steps_per_second(env: gym.Env, steps: int, seed: int) -> float:
    """Run ``steps`` random-action steps (resetting on episode end); steps per second."""
    env.reset(seed=seed)
    env.action_space.seed(seed)
    sample = env.action_space.sample
    step, reset = env.step, env.reset
    t0 = time.perf_counter()
    for _ in range(steps):
        _, _, terminated, truncated, _ = step(sample())
        if terminated or truncated:
            reset()
    return steps / (time.perf_counter() - t0)


def measure(env: gym.Env, steps: int, repeats: int) -> list[float]:
    """Steps/s of each repeat, after one untimed warm-up run."""
    steps_per_second(env, max(steps // 10, 10), seed=0)
    return [steps_per_second(env, steps, seed=r + 1) for r in range(repeats)]


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Run the benchmark and print the figures; returns them as a dict."""
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--quick", action="store_true", help="fewer steps and repeats (a few seconds)")
    parser.add_argument("--repeats", type=int, default=None, help="timed repeats per env (median reported)")
    parser.add_argument("--skip-highway", action="store_true", help="measure drx only")
    parser.add_argument("--profile", action="store_true", help="print a cProfile of the drx loop and exit")
    parser.add_argument("--json", type=Path, default=None, help="also write the figures to this file")
    args = parser.parse_args(argv)

    threads = limit_threads()
    drx_steps, hw_steps = (3_000, 150) if args.quick else (20_000, 600)
    repeats = args.repeats or (3 if args.quick else 5)

    env, drx_label = make_drx()
    if args.profile:
        import cProfile
        import pstats

        steps_per_second(env, 2000, seed=0)
        prof = cProfile.Profile()
        prof.runcall(steps_per_second, env, drx_steps, 1)
        pstats.Stats(prof).sort_stats("tottime").print_stats(18)
        return {}
    drx_runs = measure(env, drx_steps, repeats)
    drx_rate = statistics.median(drx_runs)
    result: dict[str, Any] = {
        "threads": threads,
        "drx": {"label": drx_label, "steps": drx_steps, "runs": drx_runs, "median": drx_rate},
    }
    print(f"threads: {threads}")
    print(
        f"drx/DeepRacer-v0 ({drx_label}): {drx_rate:,.0f} steps/s  (median of {repeats} x {drx_steps} steps)"
    )
    if not args.skip_highway:
        hw_env, hw_label = make_highway()
        hw_runs = measure(hw_env, hw_steps, repeats)
        hw_rate = statistics.median(hw_runs)
        result["highway"] = {"label": hw_label, "steps": hw_steps, "runs": hw_runs, "median": hw_rate}
        result["ratio"] = drx_rate / hw_rate
        print(f"highway-env ({hw_label}): {hw_rate:,.0f} steps/s  (median of {repeats} x {hw_steps} steps)")
        print(f"ratio drx / highway-env: {drx_rate / hw_rate:,.1f}x")
    realtime = 15.0
    print(f"drx vs DeepRacer real time (15 steps/s): {drx_rate / realtime:,.0f}x")
    if args.json:
        args.json.write_text(json.dumps(result, indent=2))
    return result


if __name__ == "__main__":
    main()
    sys.exit(0)
