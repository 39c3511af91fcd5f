"""PPO's update and the sampling policy's forward pass, on the CPU and on a CUDA GPU when there is one.

For each network (``compact``, ``shallow``, ``deep``) and each device (the CPU, then every CUDA
device torch finds) this builds drx's PPO exactly as ``drx train --device D`` does
(:func:`drx.train.algorithms.build_algorithm`, DeepRacer's default hyperparameters: batch 64,
10 epochs) for DeepRacer's default discrete car on the oval, and times:

* **the update**: :meth:`drx.train.ppo.EpisodicPPO.train` over a rollout buffer of ``--steps``
  random camera frames (whole "episodes", advantages computed), reported as steps of experience
  the update gets through a second (buffer steps / update seconds; it scales with the steps, so
  a short buffer measures the same rate as an iteration's thousands of steps). On the CPU the
  update gets the threads ``drx train`` gives it (:func:`drx.train.networks.useful_threads`);
* **the forward pass that samples**: the policy on one frame (action, value, log-probability),
  as :class:`drx.train.rollout.EpisodeDriver` runs it every step, the frame copied to the device
  and the action back (on the CPU: one thread, as the trainer samples). Its inverse is the
  sampling rate the policy alone would allow, the simulator not counted.

Each figure is the median of ``--repeats`` (the update) or ``--calls`` (the forward pass) timings
after a warm-up (one epoch of the update; on a GPU that includes cuDNN's choice of kernels),
with the spread. The header names torch's build, the CPU (model, cores, load average before and
after) and each GPU (``torch.cuda.get_device_name``, memory, compute capability).

The default run takes under a minute on a 2-core machine (``deep``'s CPU update is most of it);
``--networks compact shallow`` or ``--devices cuda`` shorten it.

On a GPU machine: the project pins ``torch==2.13.0``, which ``make setup`` installs as the CPU
build (``2.13.0+cpu``). Replace it in the virtual environment with the CUDA build from PyTorch's
index, whose name is ``https://download.pytorch.org/whl/cu<CUDA version without the dot>``
(``cu126`` for CUDA 12.6; pick one that pytorch.org lists for torch 2.13 and that the driver
supports: ``nvidia-smi`` shows the highest CUDA version it runs)::

    .venv/bin/pip install "torch==2.13.0+cu126" --index-url https://download.pytorch.org/whl/cu126
    .venv/bin/drx info                        # device (auto): cuda:0 (<GPU>; torch 2.13.0+cu126, CUDA 12.6)
    .venv/bin/python benchmarks/gpu_throughput.py

Run: ``python benchmarks/gpu_throughput.py [--networks compact shallow deep] [--devices cpu cuda]
[--steps 64] [--repeats 5] [--calls 100]``.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # as `drx train` runs (drx/train/__init__.py)

import numpy as np  # noqa: E402
import torch as th  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from drx.settings.hyperparameters import Hyperparameters  # noqa: E402
from drx.sim.env import DeepRacerEnv  # noqa: E402
from drx.train.algorithms import build_algorithm  # noqa: E402
from drx.train.device import describe_device, torch_build  # noqa: E402
from drx.train.networks import useful_threads  # noqa: E402
from drx.train.ppo import EpisodicPPO  # noqa: E402
from drx.vehicle import default_vehicle  # noqa: E402

NETWORKS = ("compact", "shallow", "deep")
EPISODE_STEPS = 32  # [steps] the random buffer's "episodes" (an episode start every 32 steps)


def cpu_name() -> str:
    """The CPU's model name (Linux's /proc/cpuinfo, else the platform's answer)."""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def cores() -> int:
    """Cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:
        return os.cpu_count() or 1


def gpu_line(index: int) -> str:
    """``cuda:0 NVIDIA A10G, 22.5 GB, compute 8.6``."""
    props = th.cuda.get_device_properties(index)
    return (
        f"cuda:{index} {th.cuda.get_device_name(index)}, {props.total_memory / 2**30:.1f} GB, "
        f"compute {props.major}.{props.minor}"
    )


def sync(device: str) -> None:
    """Wait for the device's queued work (a GPU runs it asynchronously)."""
    if device.startswith("cuda"):
        th.cuda.synchronize(device)


def median_spread(values: list[float]) -> tuple[float, float, float]:
    """(median, min, max)."""
    return statistics.median(values), min(values), max(values)


def build(network: str, device: str) -> EpisodicPPO:
    """drx's PPO for the default car with ``network`` on ``device``, as ``drx train`` builds it."""
    car = replace(default_vehicle(), network=network)
    env = DeepRacerEnv(track="oval", vehicle=car)
    model = build_algorithm(env, network, Hyperparameters.default("ppo"), seed=0, device=device)
    assert isinstance(model, EpisodicPPO)
    return model


def fill(model: EpisodicPPO, steps: int, rng: np.random.Generator) -> None:
    """The rollout buffer holding ``steps`` random frames in whole episodes, advantages computed."""
    buffer = model.rollout_buffer
    buffer.reset()
    space = model.observation_space
    n_actions = int(model.action_space.n)  # type: ignore[attr-defined]
    for i in range(steps):
        obs = rng.integers(0, 256, (1, *space.shape), dtype=np.uint8)  # type: ignore[misc]
        buffer.add(
            obs, np.array([[rng.integers(n_actions)]]), np.array([rng.normal()]),  # type: ignore[arg-type]
            np.array([i % EPISODE_STEPS == 0]), th.tensor([rng.normal()]), th.tensor([-np.log(n_actions)]),
        )  # fmt: skip
    buffer.finish(last_values=th.zeros(1), dones=np.ones(1, dtype=bool))  # type: ignore[attr-defined]


def time_update(model: EpisodicPPO, device: str, steps: int, repeats: int) -> list[float]:
    """Seconds of ``repeats`` updates over a ``steps``-step buffer (after a one-epoch warm-up)."""
    rng = np.random.default_rng(0)
    fill(model, steps, rng)
    epochs, model.n_epochs = model.n_epochs, 1
    model.train()  # warm-up: allocations, cuDNN's kernel choice
    model.n_epochs = epochs
    times = []
    for _ in range(repeats):
        fill(model, steps, rng)
        sync(device)
        start = time.perf_counter()
        model.train()
        sync(device)
        times.append(time.perf_counter() - start)
    return times


def time_forward(model: EpisodicPPO, device: str, calls: int) -> list[float]:
    """Seconds of ``calls`` sampling forward passes on one frame (frame in, action out)."""
    from stable_baselines3.common.utils import obs_as_tensor

    policy = model.policy
    policy.set_training_mode(False)
    rng = np.random.default_rng(1)
    frames = [rng.integers(0, 256, (1, *model.observation_space.shape), dtype=np.uint8) for _ in range(8)]  # type: ignore[misc]
    step: Callable[[np.ndarray], None]

    def step(frame: np.ndarray) -> None:
        with th.no_grad():
            action, value, log_prob = policy(obs_as_tensor(frame, policy.device))  # type: ignore[arg-type]
        action.cpu().numpy()  # what EpisodeDriver hands the env (a GPU syncs here)
        float(value[0]), float(log_prob[0])

    for i in range(5):
        step(frames[i % len(frames)])
    times = []
    for i in range(calls):
        sync(device)
        start = time.perf_counter()
        step(frames[i % len(frames)])
        times.append(time.perf_counter() - start)
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--networks", nargs="+", default=list(NETWORKS), choices=NETWORKS)
    parser.add_argument(
        "--devices", nargs="+", default=None, help="cpu, cuda, cuda:N [default: cpu and every CUDA device]"
    )
    parser.add_argument("--steps", type=int, default=64, help="steps in the update's buffer (64: one batch)")
    parser.add_argument("--repeats", type=int, default=5, help="timed updates per network and device")
    parser.add_argument("--calls", type=int, default=100, help="timed forward passes per network and device")
    args = parser.parse_args()

    cuda = th.cuda.is_available()
    devices = args.devices or ["cpu", *(f"cuda:{i}" for i in range(th.cuda.device_count() if cuda else 0))]
    build_info = torch_build()
    began = time.monotonic()
    load_before = os.getloadavg()[0]
    toolkit = (build_info.gpu_toolkit if build_info else None) or "no CUDA"
    print(
        f"torch {th.__version__} ({toolkit}); {cores()} cores, {cpu_name()}; load average {load_before:.2f}"
    )
    for i in range(th.cuda.device_count() if cuda else 0):
        print(f"GPU {gpu_line(i)}")
    if not cuda:
        print(f"no CUDA device: {describe_device('cpu')}; only the CPU is measured")
    print(
        f"PPO update: DeepRacer's batch 64 and 10 epochs over a {args.steps}-step buffer, median of "
        f"{args.repeats} (min-max); forward: one frame, median of {args.calls}"
    )
    header = (
        f"{'network':8s} {'device':34s} {'update steps/s':>22s} {'forward ms':>18s} {'sampling steps/s':>17s}"
    )
    print(header)
    all_threads = th.get_num_threads()
    for network in args.networks:
        for device in devices:
            gpu = device.startswith("cuda")
            label = gpu_line(int(device.partition(":")[2] or 0)).split(",")[0] if gpu else "cpu"
            model = build(network, device)
            threads = all_threads if gpu else useful_threads(network, cores())
            th.set_num_threads(threads)
            update = median_spread(
                [args.steps / t for t in time_update(model, device, args.steps, args.repeats)]
            )
            th.set_num_threads(threads if gpu else 1)  # the trainer samples on one thread
            forward = median_spread([t * 1000 for t in time_forward(model, device, args.calls)])
            if not gpu:
                label += f" ({threads} thread{'s' if threads > 1 else ''}, sampling 1)"
            update_text = f"{update[0]:.1f} ({update[1]:.1f}-{update[2]:.1f})"
            forward_text = f"{forward[0]:.2f} ({forward[1]:.2f}-{forward[2]:.2f})"
            rate = 1000 / forward[0]
            print(f"{network:8s} {label[:34]:34s} {update_text:>22s} {forward_text:>18s} {rate:17.0f}")
            del model
            if gpu:
                th.cuda.empty_cache()
    print(
        f"load average {load_before:.2f} -> {os.getloadavg()[0]:.2f}; {time.monotonic() - began:.0f} s in all"
    )


if __name__ == "__main__":
    main()
