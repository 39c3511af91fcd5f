"""What a model's best and last checkpoints earn under the reward they were trained on.

A run's last checkpoint can lap slower than its best (``docs/RACING.md``). That is either the
training losing what it found (the last checkpoint earns *less* of the reward) or the reward
preferring the slower lap (it earns *more*). This script tells the two apart: it drives each
checkpoint of a trained model in its own training environment (its track, car and
``reward_function.py``, training's episode rules: the episode ends at the lap's end or on the
first off-track) from ``--episodes`` starts spread evenly round the lap, as DeepRacer's round
robin spreads training episodes, once with the actions sampled as training samples them and
once with the most probable action (as evaluation drives). Every checkpoint sees the same
starts and the same simulator noise.

Per checkpoint and way of driving it prints the mean discounted return (the model's own
discount: what the critics estimate), the mean undiscounted return, the share of episodes that
reach the lap's end, the mean progress, and the mean time of the finished episodes (a lap from
a start that is not the line is a lap all the same), with the core count and the load.

Run: ``python benchmarks/checkpoint_returns.py --home DRX_HOME --model NAME [--episodes 20]
[--seed 0]`` (``benchmarks/race_pace.py --keep`` prints the data homes it leaves; its models
are named after the experiment: ``exp1``, ``exp2`` ...).
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

CHECKPOINTS = ("best", "last")
HOME_OVERRIDES = ("DRX_DATABASE_URL", "DRX_ARTIFACTS_URL")  # settings that would point drx past DRX_HOME


@dataclass(frozen=True)
class Episode:
    """One driven episode: its returns and how far it got."""

    discounted: float
    total: float
    progress: float
    finished: bool
    seconds: float


def drive(env: Any, policy: Any, start: float, seed: int, sampled: bool, discount: float) -> Episode:
    """Drive one training episode from ``start`` (a fraction of the lap) and sum its rewards."""
    import torch as th

    th.manual_seed(seed)  # the same action noise for every checkpoint
    obs, _ = env.reset(seed=seed, options={"start": start})
    discounted = total = 0.0
    weight, seconds, progress, done = 1.0, 0.0, 0.0, False
    info: dict[str, Any] = {}
    while not done:
        action, _ = policy.predict(obs, deterministic=not sampled)
        obs, reward, terminated, truncated, info = env.step(action)
        discounted += weight * float(reward)
        total += float(reward)
        weight *= discount
        seconds += float(info.get("step_time", 0.0))
        progress = float(info.get("progress", progress))
        done = bool(terminated or truncated)
    return Episode(discounted, total, progress, "lap_time" in info, seconds)


def probe(home: Path, model_name: str, episodes: int, seed: int) -> list[str]:
    """The lines to print: one per checkpoint and way of driving."""
    os.environ["DRX_HOME"] = str(home)
    for elsewhere in HOME_OVERRIDES:  # the registry and the files of *this* data home, not a shared one
        os.environ.pop(elsewhere, None)
    from drx.evaluate.theoretical_lap import PARAMS_KEY, racing_line_waypoints
    from drx.interchange.package.onnx_policy import load_policy
    from drx.services.models import get_model, model_artifacts_dir
    from drx.services.tracks import find_track, load_entry
    from drx.sim.env import DeepRacerEnv
    from drx.train.checkpoint import checkpoint_path, read_meta

    model = get_model(model_name)
    vehicle = model.vehicle()
    discount = model.hyperparameter_settings().discount_factor
    folder = model_artifacts_dir(model.name)
    track = load_entry(find_track(model.track_name))
    env = DeepRacerEnv(
        track=track,
        vehicle=vehicle,
        reward_function=folder / "reward_function.py",  # the code the model trained on, trusted then
        mode="training",
        extra_params={PARAMS_KEY: racing_line_waypoints(track)},
    )
    lines = [
        f"{model.name}: {model.track_name}, {vehicle.summary()}, discount {discount:g}; "
        f"{episodes} episodes from starts spread round the lap, seed {seed}"
    ]
    for which in CHECKPOINTS:
        path = checkpoint_path(folder, which)
        policy = load_policy(path, vehicle)
        iteration = read_meta(path).get("iteration")
        for sampled in (True, False):
            runs = [
                drive(env, policy, k / episodes, seed + k, sampled, discount) for k in range(episodes)
            ]
            laps = [r.seconds for r in runs if r.finished]
            mean_lap = f"{statistics.fmean(laps):.2f} s" if laps else "-"
            lines.append(
                f"  {which:4s} (iteration {iteration}) {'sampled' if sampled else 'most probable'}: "
                f"discounted return {statistics.fmean(r.discounted for r in runs):9.1f}, "
                f"total {statistics.fmean(r.total for r in runs):9.1f}, "
                f"finished {len(laps)}/{episodes}, "
                f"progress {statistics.fmean(r.progress for r in runs):5.1f}%, "
                f"finished laps' mean time {mean_lap}"
            )
    env.close()
    return lines


def main() -> None:
    """Parse the arguments, probe the model, print the lines."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--home", type=Path, required=True, help="the data home holding the model")
    parser.add_argument("--model", required=True, help="the model's name")
    parser.add_argument("--episodes", type=int, default=20, help="episodes per checkpoint and way")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    if not (args.home / "drx.db").is_file():
        parser.error(f"--home {str(args.home)!r} holds no drx data home (no drx.db); give one.")
    if args.episodes < 1:
        parser.error(f"--episodes {args.episodes} is too few; give 1 or more.")
    cores = len(os.sched_getaffinity(0))
    print(f"cores: {cores}, load average at start: {os.getloadavg()[0]:.1f}", flush=True)
    try:
        lines = probe(args.home.resolve(), args.model, args.episodes, args.seed)
    except Exception as exc:  # a DrxError names the value and the fix
        from drx.errors import DrxError

        if not isinstance(exc, DrxError):
            raise
        print(f"checkpoint_returns.py: {exc}", file=sys.stderr)
        sys.exit(2)
    print("\n".join(lines))
    print(f"load average at the end: {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
