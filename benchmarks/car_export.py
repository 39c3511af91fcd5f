"""The car export per network: time to write ``model.pb``, its size, and one frame's inference.

Usage: ``python benchmarks/car_export.py [--frames N]``

For each drx network (front camera, discrete PPO, untrained weights: sizes and times do not
depend on training) this writes the frozen graph (:func:`drx.interchange.car.car_graph.policy_to_graph`),
compiles it with OpenVINO for the CPU and times one inference on a real drx camera frame, batch
1, as the car runs it and as ``drx evaluate`` drives an imported DeepRacer model; the torch
policy's ``predict`` on the same frame is timed beside it. One thread each; the median of
``--frames`` runs. Needs ``pip install openvino``.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from functools import partial
from pathlib import Path

import numpy as np
import torch

from drx.interchange.car.car_graph import input_names, policy_to_graph
from drx.settings.hyperparameters import Hyperparameters
from drx.sim.env import DeepRacerEnv
from drx.train.algorithms import build_algorithm
from drx.vehicle import Vehicle, default_vehicle


def median_ms(fn, runs: int) -> float:
    """Median wall time of ``fn()`` over ``runs`` calls [ms], after 3 warm-up calls."""
    for _ in range(3):
        fn()
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        fn()
        times.append((time.perf_counter() - t) * 1000)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=200, help="inferences timed per network")
    args = parser.parse_args()
    import openvino as ov

    torch.set_num_threads(1)
    core = ov.Core()
    header = ("network", "write ms", "model.pb MB", "compile ms", "OpenVINO ms", "torch ms")
    print(f"{header[0]:8} " + " ".join(f"{h:>12}" for h in header[1:]))
    for network in ("shallow", "deep", "compact"):
        vehicle = Vehicle(name=network, actions=default_vehicle().actions, network=network)
        env = DeepRacerEnv(track="oval", vehicle=vehicle, mode="evaluation")
        model = build_algorithm(env, network, Hyperparameters.default("ppo"), seed=0)
        frame, _ = env.reset()
        t = time.perf_counter()
        graph = policy_to_graph(model.policy, vehicle)
        write_ms = (time.perf_counter() - t) * 1000
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "model.pb"
            path.write_bytes(graph)
            t = time.perf_counter()
            compiled = core.compile_model(
                core.read_model(str(path)),
                "CPU",
                {"INFERENCE_NUM_THREADS": 1, "INFERENCE_PRECISION_HINT": "f32"},
            )
            compile_ms = (time.perf_counter() - t) * 1000
        name = input_names(vehicle, "ppo", None)["camera"]
        port = [p for p in compiled.inputs if any(n.split(":")[0] == name for n in p.get_names())][0]
        request = compiled.create_infer_request()
        feed = {port: frame[None].astype(np.float32)}
        ov_ms = median_ms(partial(request.infer, feed), args.frames)
        torch_ms = median_ms(partial(model.policy.predict, frame, deterministic=True), args.frames)
        figures = (write_ms, len(graph) / 1e6, compile_ms, ov_ms, torch_ms)
        print(f"{network:8} " + " ".join(f"{f:12.3f}" for f in figures))


if __name__ == "__main__":
    main()
