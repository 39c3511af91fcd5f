"""What the reward guards cost per step (drx/sim/reward_guard.py): time limit, own params, exits.

Two figures, both in CPU time (robust when others share the machine), best of many
interleaved repeats:

1. one reward call: the sample ``follow_center_line`` reward called through drx's
   ``RewardFunction`` (copy of ``params``, watchdog marks, error handling) vs the bare
   function, on the ``params`` of a time trial on ``reinvent_base``;
2. the whole ``env.step`` (camera included, no Gymnasium wrappers) with the guarded reward vs
   the same env calling the bare function: the share of a step the guards take.

    python benchmarks/reward_overhead.py            # ~30 s
    python benchmarks/reward_overhead.py --quick    # a few seconds
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")

import argparse  # noqa: E402
import time  # noqa: E402
import timeit  # noqa: E402
from pathlib import Path  # noqa: E402
from typing import Any  # noqa: E402

import cv2  # noqa: E402
import numpy as np  # noqa: E402

from drx.sim.env import DeepRacerEnv  # noqa: E402
from drx.sim.params import params_at_pose  # noqa: E402
from drx.sim.reward_loader import load_reward_function  # noqa: E402
from drx.sim.track import load_track  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SHARED_TRACK = ROOT.parent / "shared" / "tracks" / "reinvent_base.npy"
REWARD = ROOT / "rewards" / "follow_center_line.py"


class _Bare:
    """The user's function with nothing around it (what the env called before the guards)."""

    def __init__(self, func: Any) -> None:
        self.func = func

    def __call__(self, params: dict[str, Any]) -> float:
        return float(self.func(params))


def call_cost(repeats: int, number: int) -> tuple[float, float]:
    """Best CPU µs per call: (guarded, bare)."""
    track = load_track(SHARED_TRACK if SHARED_TRACK.is_file() else "oval")
    x, y = track.center[5]
    params = params_at_pose(track, float(x), float(y), 0.0)
    reward = load_reward_function(REWARD)
    guarded, bare = [], []
    for _ in range(repeats):
        guarded.append(timeit.timeit(lambda: reward(params), number=number, timer=time.process_time))
        bare.append(timeit.timeit(lambda: reward.func(params), number=number, timer=time.process_time))
    return min(guarded) / number * 1e6, min(bare) / number * 1e6


def step_cost(repeats: int, steps: int) -> tuple[float, float]:
    """Best CPU µs per env step: (guarded reward, bare reward), interleaved."""
    env = DeepRacerEnv(track=str(SHARED_TRACK) if SHARED_TRACK.is_file() else "oval", reward_function=REWARD)
    guarded_fn = env.reward_fn
    bare_fn = _Bare(guarded_fn.func)
    actions = np.random.default_rng(0).integers(0, env.action_space.n, steps)  # type: ignore[attr-defined]
    out: dict[str, list[float]] = {"guarded": [], "bare": []}
    for r in range(repeats):
        order = (("guarded", guarded_fn), ("bare", bare_fn))
        for name, fn in order if r % 2 == 0 else order[::-1]:
            env.reward_fn = fn  # type: ignore[assignment]
            env.reset(seed=1)
            t0 = time.process_time()
            for a in actions:
                _, _, term, trunc, _ = env.step(a)
                if term or trunc:
                    env.reset()
            out[name].append((time.process_time() - t0) / steps)
    return min(out["guarded"]) * 1e6, min(out["bare"]) * 1e6


def main(argv: list[str] | None = None) -> None:
    """Print both figures."""
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--quick", action="store_true", help="fewer repeats (a few seconds)")
    args = parser.parse_args(argv)
    cv2.setNumThreads(1)
    repeats = 5 if args.quick else 15
    guarded, bare = call_cost(repeats, 20_000 if args.quick else 100_000)
    print(
        f"reward call: guarded {guarded:.3f} µs, bare {bare:.3f} µs, guards {guarded - bare:.3f} µs per call"
    )
    g_step, b_step = step_cost(repeats * 2, 1000 if args.quick else 3000)
    print(
        f"env.step: guarded {g_step:.2f} µs ({1e6 / g_step:,.0f} steps/CPU-s), bare {b_step:.2f} µs "
        f"({1e6 / b_step:,.0f} steps/CPU-s): the guards take {100 * (g_step - b_step) / b_step:.1f}% "
        "of a step"
    )


if __name__ == "__main__":
    main()
