"""How long one SAC gradient step takes: drx's update against Stable-Baselines3's own.

SAC takes one gradient step per environment step (DeepRacer's rule), so its training speed is
its gradient step's. This script builds drx's SAC for a continuous car (steering -30..30 deg,
speed 1.1..3 m/s) with the chosen network on A to Z Speedway (``reInvent2019_wide_cw`` from
``../shared/tracks``, else the oval) and the pursuit reward, fills its replay buffer with a few
episodes, then times, alternately, ``--steps`` gradient steps of:

* ``sb3``: SB3's ``SAC.train`` (separate actor and critic encoders: five encoder passes forward
  and three backward a step);
* ``drx``: :meth:`drx.train.sac.EpisodicSAC.train` (one encoder trained by the critic, read by
  the actor detached: three forward and one backward).

It prints the median milliseconds a step of each over ``--repeats`` rounds (wall-clock, and the
process's CPU time, which a busy machine disturbs less), their ratio, the
gradient steps (= environment steps) a second each allows, torch's thread count, the core
count and the load average.

Run: ``python benchmarks/sac_update.py [--batch-size 128] [--steps 40] [--repeats 7]
[--network compact]``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from pathlib import Path

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # as `drx train` runs (drx/train/__init__.py)

import gymnasium as gym  # noqa: E402
import torch as th  # noqa: E402
from stable_baselines3 import SAC  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SHARED_TRACK = ROOT.parent / "shared" / "tracks" / "reInvent2019_wide_cw.npy"
REWARD = ROOT / "rewards" / "pursuit.py"


def build(network: str, batch_size: int):  # noqa: ANN201 - an EpisodicSAC, imported late
    """drx's SAC for the race-pace car, its replay buffer holding a few episodes."""
    from drx.settings.hyperparameters import Hyperparameters
    from drx.sim.registration import ENV_ID, register_envs
    from drx.train.algorithms import build_algorithm
    from drx.train.sac import EpisodicSAC
    from drx.vehicle import Vehicle

    register_envs()
    car = Vehicle(name="sac", continuous=True, steering_range=(-30.0, 30.0), speed_range=(1.1, 3.0),
                  network=network)  # fmt: skip
    track = str(SHARED_TRACK) if SHARED_TRACK.is_file() else "oval"
    env = gym.make(ENV_ID, track=track, vehicle=car, reward_function=str(REWARD), mode="training",
                   disable_env_checker=True)  # fmt: skip
    settings = {"batch_size": batch_size, "learning_rate": 3e-4, "discount_factor": 0.995}
    model = build_algorithm(env, network, Hyperparameters.build("sac", settings), seed=0)
    assert isinstance(model, EpisodicSAC)
    while model.replay_buffer.size() < 4 * batch_size:  # type: ignore[union-attr]
        model.collect_episodes(5)
    return model


def time_steps(step, steps: int) -> tuple[float, float]:  # noqa: ANN001 - a callable taking a step count
    """Milliseconds a gradient step, over ``steps`` steps: wall-clock and this process's CPU time (on
    one torch thread the CPU time is what the step costs when nothing else wants the core)."""
    start, cpu = time.perf_counter(), time.process_time()
    step(steps)
    return (time.perf_counter() - start) / steps * 1000.0, (time.process_time() - cpu) / steps * 1000.0


def main() -> None:
    """Time both updates alternately and print the medians."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--batch-size", type=int, default=128, help="the race-pace experiment's 128")
    parser.add_argument("--steps", type=int, default=40, help="gradient steps timed per round")
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--network", default="compact")
    parser.add_argument("--threads", type=int, default=1, help="torch threads (drx's compact network uses 1)")
    args = parser.parse_args()
    th.set_num_threads(args.threads)
    model = build(args.network, args.batch_size)
    updates = {
        "sb3": lambda n: SAC.train(model, gradient_steps=n, batch_size=args.batch_size),
        "drx": lambda n: model.train(gradient_steps=n, batch_size=args.batch_size),
    }
    for update in updates.values():  # warm up both
        update(3)
    times: dict[str, list[float]] = {name: [] for name in updates}
    cpu_times: dict[str, list[float]] = {name: [] for name in updates}
    for _ in range(args.repeats):
        for name, update in updates.items():
            wall, cpu = time_steps(update, args.steps)
            times[name].append(wall)
            cpu_times[name].append(cpu)
    medians = {name: statistics.median(t) for name, t in times.items()}
    cpu_medians = {name: statistics.median(t) for name, t in cpu_times.items()}
    print(f"SAC gradient step, {args.network} network, batch {args.batch_size}, {args.steps} steps x "
          f"{args.repeats} rounds; torch threads {th.get_num_threads()}, cores {os.cpu_count()}, "
          f"load average {os.getloadavg()[0]:.1f}")  # fmt: skip
    for name, ms in medians.items():
        print(f"  {name}: median {ms:.1f} ms a step ({1000.0 / ms:.0f} gradient steps/s), "
              f"CPU {cpu_medians[name]:.2f} ms")  # fmt: skip
    print(f"  sb3 / drx: {medians['sb3'] / medians['drx']:.2f}x")


if __name__ == "__main__":
    main()
