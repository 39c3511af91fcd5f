"""A video of a scripted car passing boxes or bots: what object avoidance and head-to-bot look like.

No trained model needed: a pure-pursuit driver reads the same ``params`` a reward function
sees (``objects_distance``, ``objects_left_of_center``) and drives on the side of the road
away from the nearest object ahead, so it changes lanes round boxes and overtakes bots.

    python examples/race_video.py --race object-avoidance --out out/boxes.mp4
    python examples/race_video.py --race head-to-bot --bots 3 --bot-speed 0.6 --out out/bots.mp4

The frames are the env's ``rgb_array`` render: the track from above with the boxes or
bots, the car's trail and its camera frame (left stereo camera) in the corner.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import gymnasium as gym
import imageio.v2 as imageio

import drx  # noqa: F401  (registers drx/DeepRacer-v0)
from drx.evaluate.scripted import lane_changing_steer
from drx.vehicle import Vehicle

CAR = Vehicle(name="scripted", continuous=True, steering_range=(-30.0, 30.0), speed_range=(0.5, 4.0),
              sensor="stereo", lidar=True)  # fmt: skip


def avoiding_steer(env: gym.Env, lookahead: float = 0.5, warn: float = 2.0) -> float:
    """Steering [deg] towards the side of the road away from the nearest object ahead (or alongside)."""
    return max(-30.0, min(30.0, lane_changing_steer(env, lookahead, warn=warn)))


def main(argv: list[str] | None = None) -> Path:
    """Drive one lap (or until a crash) and write the video; returns its path."""
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--race", default="object-avoidance", choices=["object-avoidance", "head-to-bot"])
    parser.add_argument("--track", default="oval")
    parser.add_argument("--objects", type=int, default=4)
    parser.add_argument("--bots", type=int, default=3)
    parser.add_argument("--bot-speed", type=float, default=0.6)
    parser.add_argument("--speed", type=float, default=1.2, help="the car's speed [m/s]")
    parser.add_argument("--out", type=Path, default=Path("out/race.mp4"))
    args = parser.parse_args(argv)
    if args.race == "object-avoidance":
        race: dict[str, Any] = {"race_type": "object-avoidance", "objects": args.objects}
    else:
        race = {"race_type": "head-to-bot", "bots": args.bots, "bot_speed": args.bot_speed}
    env = gym.make("drx/DeepRacer-v0", track=args.track, vehicle=CAR, race=race, mode="evaluation",
                   render_mode="rgb_array")  # fmt: skip
    env.reset(seed=0)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    status = "in_progress"
    with imageio.get_writer(args.out, fps=15, macro_block_size=1) as video:
        video.append_data(env.render())
        for _ in range(3000):
            speed = (args.speed - 2.25) / 1.75  # CAR's continuous speed range 0.5-4 m/s
            _, _, terminated, truncated, info = env.step([avoiding_steer(env) / 30.0, speed])
            video.append_data(env.render())
            status = info["episode_status"]
            if terminated or truncated:
                break
    print(f"{args.race} on {args.track}: {status}, {info['progress']:.0f}% -> {args.out}")
    return args.out


if __name__ == "__main__":
    main()
