"""DeepRacer's model folder from a drx model: what the export costs and how the export drives.

As a new user does it, through the CLI in a fresh data home: a model on drx's default car and
``compact`` network is trained ``--minutes`` on A to Z Speedway (``reInvent2019_wide_cw``, the
``follow_center_line`` reward unless ``--reward``), then ``drx model export --for-deepracer``
distils it into DeepRacer's ``shallow`` network, writes the folder, reads it back and races the
original and the export in drx's time trial (same seed, ``--laps`` laps). ``--continuous`` trains
a continuous car instead (steering -30..30 deg, speed 1..``--max-speed`` m/s).

Prints the export's wall time and size, the distillation's agreement (and frames, seconds), and
both time trials (laps completed, fastest and mean lap, off-tracks), with the core count and the
load at the start and the end. The issue's bar: the export laps as the original does (3/3 when
the original does) with its fastest lap within 1.1x.

Run: ``python benchmarks/deepracer_export.py [--minutes 10] [--laps 3] [--seed 0] [--continuous]
[--max-speed 3] [--reward FILE] [--track NAME] [--distill-minutes 5] [--home DIR] [--json FILE]``.
``--home`` reuses a data home that already has the trained model ``bench`` (skips training).
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path
from typing import Any

from race_pace import Home  # the fresh data home and its CLI, as race_pace.py runs them

ROOT = Path(__file__).resolve().parents[1]


def _load() -> str:
    return " ".join(f"{x:.1f}" for x in os.getloadavg())


def _laps(laps: dict[str, Any] | None) -> str:
    if not laps:
        return "-"
    fastest = f"{laps['fastest']:.2f} s" if laps["fastest"] is not None else "none"
    mean = f"{laps['mean']:.2f} s" if laps["mean"] is not None else "none"
    done = f"{laps['completed']}/{laps['laps']} laps"
    return f"{done}, fastest {fastest}, mean {mean}, {laps['off_track']} off-track"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--minutes", type=float, default=10.0)
    parser.add_argument("--laps", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--continuous", action="store_true")
    parser.add_argument("--max-speed", type=float, default=3.0)
    parser.add_argument("--reward", type=Path, default=ROOT / "rewards" / "follow_center_line.py")
    parser.add_argument("--track", default="reInvent2019_wide_cw")
    parser.add_argument("--distill-minutes", type=float, default=5.0)
    parser.add_argument("--home", type=Path, default=None)
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    if args.minutes <= 0 or args.laps < 1 or args.distill_minutes <= 0:
        parser.error("--minutes and --distill-minutes must be above 0 and --laps at least 1.")
    if not args.reward.is_file():
        parser.error(f"--reward {args.reward} does not exist; give a reward_function.py file.")
    folder = args.home or Path(tempfile.mkdtemp(prefix="drx-export-bench-"))
    home = Home(str(folder))
    print(f"{os.cpu_count()} cores, load {_load()} at the start; data home {folder}")
    trained_minutes = None
    if args.home is None:
        car = ["--continuous", "--max-steering", "30", "--min-speed", "1", "--max-speed", str(args.max_speed)]
        home.drx("garage", "add", "bench-car", *(car if args.continuous else []))
        home.drx(
            "model",
            "create",
            "bench",
            "--car",
            "bench-car",
            "--track",
            args.track,
            "--reward",
            str(args.reward),
        )
        started = time.monotonic()
        home.drx("train", "bench", "--max-minutes", str(args.minutes), "--seed", str(args.seed))
        trained_minutes = (time.monotonic() - started) / 60
    out = folder / f"bench-deepracer-{time.strftime('%Y%m%d-%H%M%S')}"  # a new folder each run
    started = time.monotonic()
    result = home.drx(
        "model",
        "export",
        "bench",
        "--for-deepracer",
        "--out",
        str(out),
        "--laps",
        str(args.laps),
        "--seed",
        str(args.seed),
        "--distill-minutes",
        str(args.distill_minutes),
    )
    wall = time.monotonic() - started
    d = result.get("distillation") or {}
    original, exported = result.get("original_laps"), result.get("exported_laps")
    ratio = None
    if original and exported and original["fastest"] and exported["fastest"]:
        ratio = exported["fastest"] / original["fastest"]
    car = f"continuous 1..{args.max_speed} m/s" if args.continuous else "default (10 actions)"
    print(
        f"car {car}; track {args.track}; trained {trained_minutes or 0:.1f} min; "
        f"checkpoint {result['checkpoint']}"
    )
    size = result["size_bytes"] / 1e6
    print(
        f"export: {wall:.0f} s wall ({result['seconds']:.0f} s in drx), {size:.1f} MB, "
        f"{len(result['files'])} files"
    )
    if d:
        print(
            f"distillation: agreement {100 * d['agreement']:.1f}% of held-out frames, mean action error "
            f"{d['mean_action_error']:.3f}, value R^2 {d['value_r2']:.2f}, {d['frames']} frames, "
            f"{d['rounds']} rounds, {d['seconds']:.0f} s"
        )
    print(f"original ({result['network']}): {_laps(original)}")
    print(f"export (shallow, read back): {_laps(exported)}")
    if ratio is not None:
        print(f"fastest lap, export / original: {ratio:.3f}")
    print(f"load {_load()} at the end")
    if args.json:
        args.json.write_text(json.dumps({**result, "wall_seconds": wall, "ratio": ratio}, indent=2))


if __name__ == "__main__":
    main()
