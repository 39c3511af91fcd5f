"""How fast is one PPO update, the fast way (drx's) and SB3's way, for each network and towers setting?

For each drx network (``shallow``, ``deep``, ``compact``) and each ``towers`` setting
(``shared``, ``separate``) it builds two identical PPO models for DeepRacer's default car with
DeepRacer's default hyperparameters (batch 64; :func:`drx.train.algorithms.build_algorithm`), one
with ``fast_update`` (drx's update: :attr:`drx.train.ppo.EpisodicPPO.fast_update`) and one
without (the same update computed as SB3 computes it), and fills both rollout buffers with the
same ``--steps`` random frames (the update's speed does not depend on what the frames show).
It then times ``model.train()`` (``--epochs`` epochs over the buffer) in ``--rounds`` rounds;
in each, every setting (in reverse order on odd rounds) updates four times, SB3's way, fast,
fast, SB3's way, so that both ways share the machine's load alike. It prints per setting the
median milliseconds per minibatch each way, in wall-clock time and in CPU time of the process
(all its threads: the work, which other processes on the cores disturb less than the wall
clock), and the median over rounds of the wall-clock ratio. Torch gets the threads the trainer
would give the network (:func:`drx.train.networks.useful_threads` of ``--threads``). It prints
the core count and the load average with the figures: other processes on the cores slow a
multi-threaded update down a lot.

Run: ``python benchmarks/update_speed.py [--networks shallow,deep,compact] [--towers shared,separate]
[--threads 2] [--steps 192] [--epochs 1] [--rounds 10]`` (defaults; 4-5 minutes on 2 cores,
most of it ``deep``'s).
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # as `drx train` runs (drx/train/__init__.py)

import numpy as np  # noqa: E402
import torch as th  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

from train_throughput import make_env_factory  # noqa: E402

from drx.settings.hyperparameters import Hyperparameters  # noqa: E402
from drx.train.algorithms import build_algorithm  # noqa: E402
from drx.train.networks import useful_threads  # noqa: E402
from drx.train.ppo import EpisodicPPO  # noqa: E402

EPISODE_STEPS = 100  # a new episode every this many steps in the synthetic buffer


def build(network: str, towers: str, fast: bool, steps: int, epochs: int) -> EpisodicPPO:
    """A PPO model for the default car with ``network``, its rollout buffer full of ``steps`` random steps."""
    _, make = make_env_factory(network)
    model = build_algorithm(make("training"), network, Hyperparameters(towers=towers), seed=0)
    assert isinstance(model, EpisodicPPO)
    model.fast_update = fast
    model.n_epochs = epochs
    rng = np.random.default_rng(0)
    buffer = model.rollout_buffer
    buffer.reset()
    shape = (1, *model.observation_space.shape)  # type: ignore[misc]
    n_actions = int(model.action_space.n)  # type: ignore[attr-defined]
    for i in range(steps):
        frame = rng.integers(0, 256, shape, dtype=np.uint8)
        action = np.array(rng.integers(0, n_actions))
        reward, value, log_prob = rng.normal(), rng.normal(), -np.log(n_actions) + 0.1 * rng.normal()
        model._add_step(frame, action, float(reward), i % EPISODE_STEPS == 0, float(value), float(log_prob))
    model._close_buffer(steps, steps, steps // EPISODE_STEPS, steps // EPISODE_STEPS)
    return model


def time_update(model: EpisodicPPO) -> tuple[float, float]:
    """Wall-clock and CPU seconds of one ``model.train()``."""
    np.random.seed(0)  # the same minibatches each time
    start, cpu = time.perf_counter(), time.process_time()
    model.train()
    return time.perf_counter() - start, time.process_time() - cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--networks", default="shallow,deep,compact")
    parser.add_argument("--towers", default="shared,separate")
    parser.add_argument("--threads", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--steps", type=int, default=192)
    parser.add_argument("--epochs", type=int, default=1)
    parser.add_argument("--rounds", type=int, default=10)
    args = parser.parse_args()
    settings = [(n, t) for n in args.networks.split(",") for t in args.towers.split(",")]
    batches = args.epochs * -(-args.steps // 64)
    print(
        f"{os.cpu_count()} cores, torch {th.__version__}, {args.steps} steps x {args.epochs} epoch(s) = "
        f"{batches} minibatches of 64 per update, load {os.getloadavg()}",
        flush=True,
    )
    models = {}
    for network, towers in settings:
        for fast in (False, True):
            models[network, towers, fast] = build(network, towers, fast, args.steps, args.epochs)
    wall: dict[tuple[str, str, bool], list[float]] = {key: [] for key in models}
    cpu: dict[tuple[str, str, bool], list[float]] = {key: [] for key in models}
    ratios: dict[tuple[str, str], list[float]] = {s: [] for s in settings}
    for round_ in range(args.rounds + 1):  # round 0 warms up and is not counted
        for network, towers in settings if round_ % 2 == 0 else settings[::-1]:
            th.set_num_threads(useful_threads(network, args.threads))
            took: dict[bool, list[tuple[float, float]]] = {False: [], True: []}
            for fast in (False, True, True, False):
                took[fast].append(time_update(models[network, towers, fast]))
            if round_ == 0:
                continue
            for fast, runs in took.items():
                wall[network, towers, fast] += [w / batches for w, _ in runs]
                cpu[network, towers, fast] += [c / batches for _, c in runs]
            ratios[network, towers].append(sum(w for w, _ in took[False]) / sum(w for w, _ in took[True]))
        if round_:
            print(f"  round {round_} done, load {os.getloadavg()}", flush=True)
    print("median ms per minibatch of 64 (forward, backward, clipping, Adam step, bookkeeping):")
    for network, towers in settings:
        sb3, fast = (1000 * statistics.median(wall[network, towers, f]) for f in (False, True))
        sb3_cpu, fast_cpu = (1000 * statistics.median(cpu[network, towers, f]) for f in (False, True))
        speedup = statistics.median(ratios[network, towers])
        print(
            f"  {network:>8} {towers:>8}, {useful_threads(network, args.threads)} thread(s): "
            f"SB3's way {sb3:7.1f} (CPU {sb3_cpu:7.1f}), fast {fast:7.1f} (CPU {fast_cpu:7.1f}); "
            f"speed-up {speedup:.2f}x (CPU {sb3_cpu / fast_cpu:.2f}x)",
            flush=True,
        )
    print(f"load {os.getloadavg()}")


if __name__ == "__main__":
    main()
