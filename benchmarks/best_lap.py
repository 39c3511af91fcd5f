"""Theoretical best laps of a 4 m/s car on every track, and how close a scripted driver gets.

For each track drx ships (its own and DeepRacer's routes, :mod:`drx.sim.catalogue`) it
prints, for a continuous car with speeds up to 4 m/s and full 30 degree steering under drx's
calibrated car model
(:func:`drx.evaluate.theoretical_lap.best_lap`): the racing line's length; the
speed profile's lap on it (from rest at the start line, as DeepRacer times every
lap); the fastest lap of a scripted pure-pursuit driver that follows that line at
those speeds (or 95 % of them) with a few look-aheads in drx's simulator (noise off;
:mod:`drx.evaluate.driven_lap`) and its
ratio to the profile's (issue 10 asks for within 10 %: the profile ignores the
15 Hz control, the command delay and steering lag, and the driver's tracking
error, which cost time, and drives the minimum-curvature line, which in places
the driver's path beats); the best lap, the faster of the two; the flying lap;
the wall time of ``best_lap`` (solving and driving); and the ratio of the flying
lap to the DeepRacer league record's best lap where one is known (:data:`LEAGUE_RECORDS`: league
races run their laps on without a stop, so their best lap is a flying lap).
``--no-drive`` leaves the driver out (the best lap is then the profile's); ``--speed-scales`` sets the
shares of the profile's speeds the driver tries (default :data:`drx.evaluate.driven_lap.SPEED_SCALES`;
above 1 it pushes past the profile, to see how fast the car can lap where the profile's steady limits
are not the car's).

Run: ``python benchmarks/best_lap.py [--no-drive] [--speed-scales 0.95 1 1.1 ...] [--simulator 5|6]
[--json FILE]``.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from dataclasses import dataclass
from pathlib import Path

from drx.evaluate.theoretical_lap import best_lap
from drx.sim.catalogue import shipped_tracks
from drx.sim.dynamics import CarParams
from drx.sim.track import Track, load_track
from drx.vehicle import Vehicle


@dataclass(frozen=True)
class Record:
    """A DeepRacer league race's winning lap on a track: the best lap [s] (laps run on without a stop,
    so a flying lap), the 3-lap average [s], the race, its month, the simulator of its era and the
    leaderboard's file in aws-deepracer-community/deepracer-race-data (the community's snapshots of the
    official leaderboards; ``raw_data/leaderboards/<leaderboard arn>/FINAL.csv``, milliseconds)."""

    best_lap: float
    average: float
    race: str
    month: str
    simulator: str
    source: str


_RACE_DATA = "aws-deepracer-community/deepracer-race-data@a2cdeadf8b raw_data/leaderboards/arn:aws:deepracer:"
_V5 = _RACE_DATA + "::leaderboard/"
_V3 = _RACE_DATA + "us-east-1::leaderboard/"
# The winners of simulator 5 era time trials (2022-2023; virtual races of 3 continuous laps: in simapp 5
# ``markov/metrics/s3_metrics.py`` starts a lap's clock where the last one ended, so the best lap is a
# flying lap and is compared with drx's flying lap), and the 2020 races issue 10 took its records from
# (simulator 3 era, another car: shown, not held to the target).
LEAGUE_RECORDS = {
    "2022_june_pro": Record(17.685, 17.971, "July 2023 Qualifier (rosscomp1)", "2023-07", "5",
                            _V5 + "45b5f83d-bd27-4a7c-9f36-72c75e1974e6"),
    "FS_June2020": Record(17.134, 17.443, "Innovate Preseason (rosscomp1)", "2023-02", "5",
                          _V5 + "95890002-29ba-470f-bea0-9f366a02f8eb"),
    "2022_reinvent_champ": Record(11.792, 11.996, "Winter Open (JJ)", "2023-01", "5",
                                  _V5 + "c5215a8b-7ca6-42d2-afcf-3edf7a7a9f4d"),
    "reInvent2019_track": Record(7.198, 7.686, "May 2020 Qualifier (Kuei-NCTU-CGI)", "2020-05", "3",
                                 _V3 + "summit-season-2020-05-tt"),
    "Spain_track": Record(25.181, 25.839, "F1 ProAm May 2020 Qualifier (JJ)", "2020-05", "3",
                          _V3 + "virtual-season-2020-05-tt"),
}  # fmt: skip
# Issue 25's target for drx's flying lap / a simulator 5 era record's best lap.
RECORD_RATIO_TARGET = (0.85, 1.0)
CAR = Vehicle(name="fast-4ms", continuous=True, steering_range=(-30.0, 30.0), speed_range=(0.5, 4.0))


def tracks() -> list[Track]:
    """drx's own tracks, then DeepRacer's routes, as shipped in the package."""
    shipped = shipped_tracks()
    return [load_track(e.path) for e in shipped if e.source == "drx"] + [
        load_track(e.path) for e in shipped if e.source == "deepracer"
    ]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--no-drive", action="store_true", help="Skip the scripted driver.")
    parser.add_argument("--json", type=Path, help="Also write the rows to this JSON file.")
    parser.add_argument("--tracks", nargs="*", help="Only these tracks (by name).")
    parser.add_argument(
        "--simulator", choices=("5", "6"), default="5", help="Whose car: DeepRacer simulator 5's or 6's [5]."
    )
    parser.add_argument(
        "--speed-scales",
        nargs="+",
        type=float,
        metavar="SHARE",
        help="Shares of the profile's speeds the driver tries (default: the driver's own).",
    )
    args = parser.parse_args()
    if args.speed_scales is not None and min(args.speed_scales) <= 0:
        lowest = min(args.speed_scales)
        parser.error(f"--speed-scales {lowest:g} is not above 0; give shares such as 0.95 1 1.1.")
    known = [track.name for track in tracks()]
    unknown = [name for name in args.tracks or [] if name not in known]
    if unknown:
        parser.error(f"--tracks {unknown[0]} is not a shipped track; use one of {', '.join(known)}.")
    scales = "default" if args.speed_scales is None else " ".join(f"{x:g}" for x in args.speed_scales)
    print(
        f"cores: {os.cpu_count()}; load {os.getloadavg()[0]:.2f}; car: {CAR.summary()}, simulator "
        f"{args.simulator}'s; driver speed scales: {scales}"
    )
    header = f"{'track':22s} {'centre m':>8s} {'line m':>7s} {'profile s':>9s}"
    header += "" if args.no_drive else f" {'driver s':>8s} {'ratio':>6s}"
    header += f" {'best s':>7s} {'flying s':>8s} {'solve s':>7s} {'record':>6s} {'x rec':>5s}"
    print(header)
    rows = []
    for track in tracks():
        if args.tracks and track.name not in args.tracks:
            continue
        t0 = time.perf_counter()
        best = best_lap(track, CAR, CarParams.for_simulator(args.simulator), drive=not args.no_drive,
                        speed_scales=args.speed_scales)  # fmt: skip
        solve = time.perf_counter() - t0
        row = {
            "track": track.name,
            "centre_length": round(track.length, 3),
            "line_length": round(best.line.length, 3),
            "profile_lap": round(best.estimate_time, 3),
            "best_lap": round(best.lap_time, 3),
            "flying_lap": round(best.flying_lap_time, 3),
            "solve_seconds": round(solve, 3),
        }
        text = f"{track.name:22s} {track.length:8.2f} {best.line.length:7.2f} {best.estimate_time:9.3f}"
        if not args.no_drive:
            driven = best.driven_time
            row["scripted_lap"] = None if driven is None else round(driven, 3)
            ratio = driven / best.estimate_time if driven else None
            row["scripted_to_profile"] = None if ratio is None else round(ratio, 3)
            text += f" {driven or float('nan'):8.3f} {ratio or float('nan'):6.3f}"
        text += f" {best.lap_time:7.3f} {best.flying_lap_time:8.3f} {solve:7.2f}"
        record = LEAGUE_RECORDS.get(track.name)
        if record:
            ratio_to_record = best.flying_lap_time / record.best_lap
            row["league_record"] = record.best_lap
            row["record_simulator"] = record.simulator
            row["ratio_to_record"] = round(ratio_to_record, 3)
            text += f" {record.best_lap:6.2f} {ratio_to_record:5.2f}"
        else:
            text += f" {'-':>6s} {'-':>5s}"
        rows.append(row)
        print(text, flush=True)
    print("records (best lap of the race's winner; x rec = drx's flying lap / it; target for simulator 5 "
          f"era records {RECORD_RATIO_TARGET[0]:g}-{RECORD_RATIO_TARGET[1]:g}):")  # fmt: skip
    for row in rows:
        record = LEAGUE_RECORDS.get(str(row["track"]))
        if record is None:
            continue
        low, high = RECORD_RATIO_TARGET
        verdict = "(simulator 3 era, not a target)"
        if record.simulator == "5":
            verdict = "ok  " if low <= float(row["ratio_to_record"]) <= high else "MISS"
        print(f"  {verdict} {row['track']}: drx's flying lap {row['flying_lap']:.3f} s / the record's "
              f"{record.best_lap:.3f} s = {float(row['ratio_to_record']):.3f} (its average "
              f"{record.average:.3f} s), {record.race}, {record.month}; {record.source}/FINAL.csv")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2))


if __name__ == "__main__":
    main()
