"""SAC's training speed end to end: environment steps per wall-clock second, and where the time went.

SAC takes one gradient step per environment step (DeepRacer's rule), so its steps per minute are
what a racer waits on. This trains the race-pace car of ``benchmarks/race_pace.py`` (continuous,
steering -30..30 deg, speed 1.1..3 m/s, drx's default network) with SAC through drx's trainer (its
sampling, update and evaluation, with DeepRacer's SAC settings but the race-pace experiment's
batch 128, learning rate 0.0003 and discount 0.995) on A to Z Speedway (``reInvent2019_wide_cw``
from ``../shared/tracks``, else the oval) and the pursuit reward, for ``--seconds``, and prints
the steps per second with the seconds spent sampling, updating and evaluating, the torch threads,
the core count and the load average. ``--repeats`` runs it again (new seed each) and prints the
median. ``benchmarks/ab_revisions.py`` compares two revisions with it in one run.

Run: ``python benchmarks/sac_throughput.py [--seconds 60] [--repeats 1] [--network compact]``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")  # as `drx train` runs (drx/train/__init__.py)

import gymnasium as gym  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
SHARED_TRACK = ROOT.parent / "shared" / "tracks" / "reInvent2019_wide_cw.npy"
REWARD = ROOT / "rewards" / "pursuit.py"


def train_once(seconds: float, network: str, seed: int) -> dict[str, float]:
    """Train SAC for ``seconds``; steps/s and the phases' seconds."""
    from drx.settings.hyperparameters import Hyperparameters
    from drx.settings.stop import StopConditions
    from drx.sim.registration import ENV_ID, register_envs
    from drx.train.trainer import Trainer, TrainingSpec
    from drx.vehicle import Vehicle

    register_envs()
    car = Vehicle(name="sac", continuous=True, steering_range=(-30.0, 30.0), speed_range=(1.1, 3.0),
                  network=network)  # fmt: skip
    track = str(SHARED_TRACK) if SHARED_TRACK.is_file() else "oval"

    def make(mode: str) -> gym.Env:
        return gym.make(ENV_ID, track=track, vehicle=car, reward_function=str(REWARD), mode=mode,
                        disable_env_checker=True)  # fmt: skip

    settings = {"batch_size": 128, "learning_rate": 3e-4, "discount_factor": 0.995}
    hp = Hyperparameters.build("sac", settings)
    with tempfile.TemporaryDirectory() as folder:
        spec = TrainingSpec(vehicle=car, hyperparameters=hp, stop=StopConditions(max_minutes=seconds / 60.0),
                            folder=Path(folder), env_factory=make, seed=seed)  # fmt: skip
        trainer = Trainer(spec)
        start = time.monotonic()
        result = trainer.run()
        wall = time.monotonic() - start
    done = result.summaries
    return {
        "steps": result.steps,
        "seconds": wall,
        "steps_per_second": result.steps / wall,
        "sampling": sum(s.extra.get("collect_seconds", 0.0) for s in done),
        "update": sum(s.extra.get("update_seconds", 0.0) for s in done),
        "evaluation": sum(s.extra.get("eval_seconds", 0.0) for s in done),
        "iterations": len(done),
        "threads": trainer.threads,
    }


def main() -> None:
    """Train, print each run and the median."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--network", default="compact", choices=("compact", "shallow", "deep"))
    args = parser.parse_args()
    if args.seconds <= 0 or args.repeats < 1:
        parser.error(
            f"--seconds {args.seconds:g} and --repeats {args.repeats} must be above 0; give e.g. 60 and 1."
        )
    rates = []
    for seed in range(args.repeats):
        run = train_once(args.seconds, args.network, seed)
        rates.append(run["steps_per_second"])
        print(f"SAC {args.network}: {run['steps_per_second']:.1f} steps/s ({run['steps']:.0f} steps in "
              f"{run['seconds']:.0f} s, {run['iterations']:.0f} iterations; sampling "
              f"{run['sampling']:.1f} s, update {run['update']:.1f} s, evaluation {run['evaluation']:.1f} s; "
              f"torch threads {run['threads']:.0f}, cores {os.cpu_count()}, "
              f"load {os.getloadavg()[0]:.1f})", flush=True)  # fmt: skip
    print(f"median: {statistics.median(rates):.1f} steps/s")


if __name__ == "__main__":
    main()
