"""How much faster could one PPO minibatch update get from this machine's cores, threaded or split?

With DeepRacer's default hyperparameters (batch 64, 10 epochs) the ``shallow`` network's update is
most of a training iteration in drx (``benchmarks/train_throughput.py`` prints the share), so what
rollout workers can gain is bounded by it (Amdahl), and what remains is how the update itself uses
the cores, for one worker and many alike. This script times one
minibatch update (forward, backward, gradient clipping, Adam step) of the ``shallow`` policy on
64 camera frames:

* in one process with 1 and with all torch threads (what ``drx train`` runs: the update gets every
  core, :func:`drx.train.networks.useful_threads`);
* with 1 thread on half the minibatch (32 frames), with the Adam step timed apart: what each of two
  data-parallel processes would spend, had the update been split across them (each half a
  minibatch, gradients summed, one Adam step), without counting the gradient exchange.

It prints the medians and the best speed-up such a data-parallel update could have over the
all-threads update on this machine: ``t(all threads) / (t_half(forward+backward) + t(Adam) / 2)``
(the Adam step shared out too), an upper bound since the exchange of 5.9 million gradients per
minibatch costs extra.

Run: ``python benchmarks/update_threads.py [--repeats 15] [--network shallow]``.
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
from gymnasium import spaces  # noqa: E402
from stable_baselines3.common.policies import ActorCriticPolicy  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from drx.train.networks import count_parameters, policy_kwargs_for  # noqa: E402


def time_update(network: str, batch: int, threads: int, repeats: int) -> tuple[float, float]:
    """Median seconds of forward + backward + clipping, and of the Adam step, for one minibatch."""
    th.set_num_threads(threads)
    th.manual_seed(0)
    obs_space = spaces.Box(0, 255, (1, 120, 160), np.uint8)
    policy = ActorCriticPolicy(obs_space, spaces.Discrete(10), lambda _: 3e-4,
                               **policy_kwargs_for(network, obs_space))  # fmt: skip
    frames = th.rand(batch, 1, 120, 160) * 255
    actions = th.randint(0, 10, (batch,))
    grads, steps = [], []
    for _ in range(repeats + 2):  # two warm-ups
        t0 = time.perf_counter()
        values, log_prob, entropy = policy.evaluate_actions(frames, actions)
        loss = values.pow(2).mean() - log_prob.mean() - entropy.mean()  # type: ignore[union-attr]
        policy.optimizer.zero_grad()
        loss.backward()
        th.nn.utils.clip_grad_norm_(policy.parameters(), 0.5)
        t1 = time.perf_counter()
        policy.optimizer.step()
        t2 = time.perf_counter()
        grads.append(t1 - t0)
        steps.append(t2 - t1)
    return statistics.median(grads[2:]), statistics.median(steps[2:])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=15)
    parser.add_argument("--network", default="shallow", choices=("shallow", "deep", "compact"))
    args = parser.parse_args()
    cores = os.cpu_count() or 1
    obs_space = spaces.Box(0, 255, (1, 120, 160), np.uint8)
    n_params = count_parameters(
        ActorCriticPolicy(obs_space, spaces.Discrete(10), lambda _: 3e-4,
                          **policy_kwargs_for(args.network, obs_space))  # fmt: skip
    )
    print(f"cores: {cores}; load average {os.getloadavg()[0]:.2f}; network {args.network} "
          f"({n_params:,} parameters); medians of {args.repeats} minibatch updates")  # fmt: skip
    one = time_update(args.network, 64, 1, args.repeats)
    every = time_update(args.network, 64, cores, args.repeats)
    half = time_update(args.network, 32, 1, args.repeats)
    for label, (grad, step) in (
        ("64 frames, 1 thread", one), (f"64 frames, {cores} threads", every), ("32 frames, 1 thread", half),
    ):  # fmt: skip
        print(f"  {label:22s} forward+backward {grad * 1000:6.1f} ms  Adam {step * 1000:5.1f} ms  "
              f"total {(grad + step) * 1000:6.1f} ms")  # fmt: skip
    threads_gain = sum(one) / sum(every)
    split = half[0] + half[1] / 2
    print(f"all threads vs one: {threads_gain:.2f}x")
    print(f"two data-parallel 1-thread processes, gradient exchange not counted: at most "
          f"{sum(every) / split:.2f}x the all-threads update")  # fmt: skip


if __name__ == "__main__":
    main()
