"""Environment steps per second on one core: drx/DeepRacer-v0 vs highway-env's racetrack-v0.

drx is measured in its three race types: the time trial with DeepRacer's default car
(one camera), and object avoidance (3 boxes, random places every episode) and
head-to-bot (3 bots at 1 m/s changing lanes) with the stereo camera + lidar car of
``garage/stereo-lidar.toml``; the target for the last two is at least half the time
trial's figure (they render two camera frames and boxes, and scan the lidar). The
time trial with the stereo + lidar car is reported too, to tell the sensors' cost from the
objects'.

Both loops: random actions (drawn before the clock starts), a 160x120 grayscale camera-like
observation, one frame per step at 15 Hz, resets on episode end, the whole Gymnasium stack
(``gymnasium.make`` wrappers included). drx uses the sample centre-line reward
(``rewards/follow_center_line.py``) on ``reinvent_base`` from ``../shared/tracks``
(else a project track). highway-env's racetrack gets ``GrayscaleObservation``
(160x120, one frame, DeepRacer's grey weights) in two variants: its shipped
defaults otherwise (a step = 1/5 s, one other car), and matched to drx
(``policy_frequency`` 15 so a step is one 1/15 s frame, no other cars).

Everything is limited to one thread (OMP/MKL/OpenBLAS, ``cv2.setNumThreads(1)``,
``torch.set_num_threads(1)``; ``--pin`` also pins the process to one CPU). The
repeats of all envs are interleaved and medians reported, both wall-clock
steps/s and steps per CPU-second (robust when others share the machine).

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

gym.logger.min_level = 40  # silence "racetrack-v0 is out of date": v0 is the env the issue names

ROOT = Path(__file__).resolve().parents[1]
SHARED_TRACK = ROOT.parent / "shared" / "tracks" / "reinvent_base.npy"
REWARD = ROOT / "rewards" / "follow_center_line.py"


def limit_threads(pin: bool) -> str:
    """One thread everywhere (optionally pinned to one CPU); returns a description."""
    cv2.setNumThreads(1)
    try:
        import torch

        torch.set_num_threads(1)
    except ImportError:
        pass
    pinned = ""
    if pin and hasattr(os, "sched_setaffinity"):
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


RACES = {
    "drx_tt_stereo_lidar": (None, "time trial", REWARD),
    "drx_object_avoidance": (
        {"race_type": "object-avoidance", "objects": 3, "randomize_objects": True},
        "object avoidance, 3 random boxes",
        ROOT / "rewards" / "object_avoidance.py",
    ),
    "drx_head_to_bot": (
        {"race_type": "head-to-bot", "bots": 3, "bot_speed": 1.0, "bot_lane_change": True},
        "head-to-bot, 3 bots at 1 m/s changing lanes",
        ROOT / "rewards" / "head_to_bot.py",
    ),
}


def make_drx_race(key: str) -> tuple[gym.Env, str]:
    """drx's env in a race with objects, driven by the stereo camera + lidar car."""
    import drx  # noqa: F401  (registers the env)
    from drx.garage_files import load_vehicle_toml

    race, label, reward = RACES[key]
    car = load_vehicle_toml(ROOT / "garage" / "stereo-lidar.toml", "stereo-lidar")
    track: Any = str(SHARED_TRACK) if SHARED_TRACK.is_file() else "oval"
    env = gym.make("drx/DeepRacer-v0", track=track, vehicle=car, race=race, reward_function=str(reward))
    return env, f"{label}, stereo + lidar, reward {reward.name}"


GRAYSCALE = {
    "type": "GrayscaleObservation",
    "observation_shape": (160, 120),
    "stack_size": 1,
    "weights": [0.2989, 0.5870, 0.1140],
}
HIGHWAY_VARIANTS = {
    # racetrack-v0 as shipped, only the observation swapped for a camera-like image.
    "default": (
        {"observation": GRAYSCALE},
        "racetrack-v0 defaults (5 Hz policy, 1 other car), grayscale 160x120",
    ),
    # Matched to drx: one step = one 1/15 s frame, no other vehicles.
    "matched": (
        {"observation": GRAYSCALE, "policy_frequency": 15, "other_vehicles": 0},
        "racetrack-v0 at 15 Hz policy, no other cars, grayscale 160x120",
    ),
}


def make_highway(variant: str) -> tuple[gym.Env, str]:
    """highway-env's racetrack-v0 with a 160x120 grayscale image observation."""
    import highway_env  # noqa: F401  (registers its envs)

    config, label = HIGHWAY_VARIANTS[variant]
    return gym.make("racetrack-v0", config=config), label


def run_steps(env: gym.Env, steps: int, seed: int) -> tuple[float, float]:
    """Run ``steps`` random-action steps (resetting on episode end).

    :return: ``(wall-clock steps/s, steps per CPU-second of this process)``.
    """
    env.reset(seed=seed)
    env.action_space.seed(seed)
    # Drawn before the clock starts: Gymnasium's ``sample()`` costs about as much as a tenth of drx's
    # step, and a training loop gets its actions from the policy, not from the action space.
    actions = [env.action_space.sample() for _ in range(steps)]
    step, reset = env.step, env.reset
    w0, c0 = time.perf_counter(), time.process_time()
    for action in actions:
        _, _, terminated, truncated, _ = step(action)
        if terminated or truncated:
            reset()
    return steps / (time.perf_counter() - w0), steps / max(time.process_time() - c0, 1e-9)


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Run the benchmark and print the figures; returns them as a dict."""
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--quick", action="store_true", help="fewer steps and repeats (a few seconds)")
    parser.add_argument("--repeats", type=int, default=None, help="timed repeats per env (median reported)")
    parser.add_argument("--skip-highway", action="store_true", help="measure drx only")
    parser.add_argument("--skip-races", action="store_true", help="measure the time trial only")
    parser.add_argument("--pin", action="store_true", help="pin the process to one CPU")
    parser.add_argument("--profile", action="store_true", help="print a cProfile of the drx loop and exit")
    parser.add_argument("--json", type=Path, default=None, help="also write the figures to this file")
    args = parser.parse_args(argv)

    threads = limit_threads(args.pin)
    drx_steps, hw_steps = (3_000, 150) if args.quick else (20_000, 600)
    repeats = args.repeats or (3 if args.quick else 7)

    envs: dict[str, tuple[gym.Env, str, int]] = {}
    env, label = make_drx()
    envs["drx"] = (env, label, drx_steps)
    if args.profile:
        import cProfile
        import pstats

        run_steps(env, 2000, seed=0)
        prof = cProfile.Profile()
        prof.runcall(run_steps, env, drx_steps, 1)
        pstats.Stats(prof).sort_stats("tottime").print_stats(18)
        return {}
    if not args.skip_races:
        for key in RACES:
            env, label = make_drx_race(key)
            envs[key] = (env, label, drx_steps)
    if not args.skip_highway:
        for variant in HIGHWAY_VARIANTS:
            env, label = make_highway(variant)
            envs[f"highway_{variant}"] = (env, label, hw_steps)
    for env, _, steps in envs.values():  # warm-up, untimed
        run_steps(env, max(steps // 10, 10), seed=0)
    # Interleave the repeats, so that a busy moment of a shared machine hits every env alike.
    runs: dict[str, list[tuple[float, float]]] = {key: [] for key in envs}
    for r in range(repeats):
        for key, (env, _, steps) in envs.items():
            runs[key].append(run_steps(env, steps, seed=r + 1))

    result: dict[str, Any] = {"threads": threads, "repeats": repeats}
    print(f"threads: {threads}; medians of {repeats} interleaved repeats")
    print(f"{'env':<74} {'steps/s (wall)':>15} {'steps/CPU-s':>12}")
    for key, (_, label, steps) in envs.items():
        wall = statistics.median(w for w, _ in runs[key])
        cpu = statistics.median(c for _, c in runs[key])
        result[key] = {"label": label, "steps": steps, "wall": wall, "cpu": cpu, "runs": runs[key]}
        name = "drx/DeepRacer-v0, " + label if key.startswith("drx") else "highway-env " + label
        print(f"{name:<74} {wall:>15,.0f} {cpu:>12,.0f}")
    drx = result["drx"]
    for key in envs:
        if key in RACES:
            share_wall, share_cpu = result[key]["wall"] / drx["wall"], result[key]["cpu"] / drx["cpu"]
            result[f"share_{key}"] = {"wall": share_wall, "cpu": share_cpu}
            line = f"{key} / time trial: {share_wall:.2f} (wall), {share_cpu:.2f} (CPU time)"
            same = result.get("drx_tt_stereo_lidar")
            if same is not None and key != "drx_tt_stereo_lidar":
                line += f"; / time trial with the same car: {result[key]['cpu'] / same['cpu']:.2f} (CPU time)"
            print(line + ("" if key == "drx_tt_stereo_lidar" else "; target >= 0.5"))
        elif key != "drx":
            ratio_wall, ratio_cpu = drx["wall"] / result[key]["wall"], drx["cpu"] / result[key]["cpu"]
            result[f"ratio_{key}"] = {"wall": ratio_wall, "cpu": ratio_cpu}
            print(f"ratio drx / {key}: {ratio_wall:,.1f}x (wall), {ratio_cpu:,.1f}x (CPU time)")
    print(f"drx vs DeepRacer's real time (15 steps/s): {drx['wall'] / 15.0:,.0f}x")
    if args.json:
        args.json.write_text(json.dumps(result, indent=2))
    return result


if __name__ == "__main__":
    main()
    sys.exit(0)
