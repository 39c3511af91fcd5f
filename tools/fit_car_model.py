"""Fit drx's car model to DeepRacer's logs and write ``drx/sim/car_calibration.py``: the command line.

The fitting itself is :mod:`drx.calibration.fit` (the replay, the residuals, the settings of each
simulator version) and :mod:`drx.calibration.calibration_module` (writing the module); this script
reads the shared logs, runs the fit and the leave-one-log-out fits, prints and writes.

System identification by open-loop replay (:mod:`drx.calibration.replay`): for windows
of 15 logged steps, drx's car starts at the logged pose and speed and is driven
by the logged commands; the fit minimises the reference point's distance from
the log after 5, 10 and 15 steps plus the heading and speed errors after 15 steps
(scipy's ``least_squares``, soft-L1 loss so the odd collision or glitch in the
logs does not dominate), over every (``--stride``-th) window of both shared log
sets, each set weighing the same. The fit replays through the batched step
(:mod:`drx.sim.dynamics_batch`, checked equal to the env's scalar step by
``tests/sim/test_dynamics_batch.py``); the figures it prints and writes come
from the scalar replay.
The mean step time is read from the logs' ``tstamp``, the step-to-step jitter from the distances
the car covers (:func:`drx.calibration.step_jitter.step_length_jitter`: the logged clock is not the car's).

The two log sets were recorded by two DeepRacer simulator versions
(deepracer-simapp 4 in the console in 2022, 5 in deepracer-for-cloud in 2023)
that drive differently: fitted together, the compromise fits neither (27 cm
median on version 5's logs, against 21 cm fitted alone), so each version is
fitted to its own logs and gets its own constants; the env uses version 5's.

Besides the car it writes, the script fits the same model once per log of the version with that log
left out, replays the log left out, and writes those cars too (``car_calibration.HELD_OUT``): what
``benchmarks/replay_fidelity.py`` reports as the car's error on logs it was not fitted to
(``docs/DYNAMICS.md``, "Held out"). ``--without LOG`` leaves a log out of the written car's fit.

Usage (from the repository root, with ``shared/`` beside it); the committed calibration::

    .venv/bin/python tools/fit_car_model.py --simulator 5 --max-evaluations 80 --without drfc-june-pro
    .venv/bin/python tools/fit_car_model.py --simulator 4 --max-evaluations 60 \
        --without console-continuous-reInvent2019 --without console-continuous-reinvent_base
    .venv/bin/python tools/fit_car_model.py --simulator 5 --dry-run   # fit and print only

The constants used for the committed calibration are the defaults below
(``FIT_SETTINGS``: which constants are held, and where the fit starts).

Refit after changing the model in :mod:`drx.sim.dynamics` (the parameter list
below must match its fitted constants), then run
``benchmarks/replay_fidelity.py``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import NoReturn

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from drx.calibration.calibration_module import OUTPUT, write_module  # noqa: E402
from drx.calibration.fit import (  # noqa: E402
    BRAKING_WEIGHT,
    FAST_WEIGHT,
    FIT_SETTINGS,
    PARAMETERS,
    SPEED_WEIGHT,
    STEADY_WEIGHT,
    STRIDE,
    FitOptions,
    fit_car,
    replay_line,
)
from drx.calibration.logs import SIMULATOR_OF_SET, shared_log_sets  # noqa: E402
from drx.errors import DrxError  # noqa: E402
from drx.sim.dynamics import CarParams  # noqa: E402

DEFAULT_LOGS = ROOT.parent / "shared" / "deepracer-logs"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--logs", type=Path, default=DEFAULT_LOGS, help="shared/deepracer-logs folder")
    parser.add_argument(
        "--stride", type=int, default=None, help=f"use every n-th window in the fit [{_per_version(STRIDE)}]"
    )
    parser.add_argument(
        "--simulator",
        choices=sorted(set(SIMULATOR_OF_SET.values())),
        default="5",
        help="the DeepRacer simulator version to fit (its logs)",
    )
    parser.add_argument(
        "--without",
        action="append",
        default=[],
        metavar="LOG",
        help="leave this log out of the fit and report on it as held out (repeatable)",
    )
    parser.add_argument(
        "--no-held-out",
        action="store_true",
        help="skip the leave-one-log-out fits (and write no held-out constants)",
    )
    parser.add_argument(
        "--fix",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="hold a constant at a value instead of fitting it (repeatable)",
    )
    parser.add_argument(
        "--free",
        action="append",
        default=[],
        metavar="NAME",
        help="fit a constant that the version's settings hold (repeatable)",
    )
    parser.add_argument(
        "--start",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="start the fit of a constant from this value (repeatable)",
    )
    parser.add_argument(
        "--speed-map",
        choices=("held", "fit"),
        default="fit",
        help="steady speed per command: a line through the held commands' speeds, or fitted with the rest",
    )
    parser.add_argument(
        "--speed-weight",
        type=float,
        default=SPEED_WEIGHT,
        help="weight of the speed error at each window's end [m per m/s]",
    )
    parser.add_argument(
        "--steady-weight",
        type=float,
        default=None,
        help="weight of the held-command turning radius errors (0: replay windows only) "
        f"[{_per_version(STEADY_WEIGHT)}, else 0]",
    )
    parser.add_argument(
        "--fast-weight",
        type=float,
        default=None,
        help="weight of the windows whose mean command is >= 2.5 m/s, relative to the others "
        f"[{_per_version(FAST_WEIGHT)}, else 1]",
    )
    parser.add_argument(
        "--braking-weight",
        type=float,
        default=None,
        help="weight of the braking figure (replay.hard_braking) against the log's "
        f"[{_per_version(BRAKING_WEIGHT)}, else 0]",
    )
    parser.add_argument("--max-evaluations", type=int, default=50, help="least-squares iterations at most")
    parser.add_argument("--dry-run", action="store_true", help="print the fit; do not write the module")
    parser.add_argument("--output", type=Path, default=OUTPUT, help="write the module here (to compare)")
    args = parser.parse_args()
    if not args.dry_run and not args.output.parent.is_dir():
        refuse(f"--output {args.output}: its folder does not exist; give a path in an existing folder.")

    settings = FIT_SETTINGS[args.simulator]
    for name in args.free:
        _known(name)
    fix = [a for a in settings["fix"] if _assignment(a)[0] not in args.free] + args.fix
    fixed, started = dict(map(_assignment, fix)), dict(map(_assignment, settings["start"] + args.start))
    try:
        every = shared_log_sets(args.logs)
    except DrxError as err:
        refuse(str(err))
    sets = {name: eps for name, eps in every.items() if SIMULATOR_OF_SET[name] == args.simulator}
    unknown = [n for n in args.without if n not in sets]
    if unknown:
        refuse(f"--without {unknown[0]} is not a log of simulator {args.simulator}; "
               f"use one of {', '.join(sets)}.")  # fmt: skip
    if not sets:
        refuse(f"no logs of simulator {args.simulator} under {args.logs}; pass --logs shared/deepracer-logs.")
    options = FitOptions(
        simulator=args.simulator,
        stride=args.stride or STRIDE[args.simulator],
        fix=fixed,
        start=started,
        speed_map=args.speed_map,
        speed_weight=args.speed_weight,
        steady_weight=_or(args.steady_weight, STEADY_WEIGHT.get(args.simulator, 0.0)),
        fast_weight=_or(args.fast_weight, FAST_WEIGHT.get(args.simulator, 1.0)),
        max_evaluations=args.max_evaluations,
        braking_weight=_or(args.braking_weight, BRAKING_WEIGHT.get(args.simulator, 0.0)),
    )
    fitted = {name: eps for name, eps in sets.items() if name not in args.without}
    report: list[str] = []
    print(f"fit on {', '.join(fitted)}:")
    try:
        fit = fit_car(fitted, options)
    except DrxError as err:
        refuse(str(err))
    held_out: dict[str, CarParams] = {}
    if not args.no_held_out and len(sets) > 1:
        for name in sets:  # leave one log out: fit on the others, score on it
            others = {n: eps for n, eps in sets.items() if n != name}
            if set(others) == set(fitted):
                held_out[name] = fit.car  # the fit above left out just this log
                continue
            print(f"fit without {name}:")
            held_out[name] = fit_car(others, options, verbose=0).car
    for name, eps in sets.items():  # the final figures from the env's own scalar step
        how = "held out" if name in args.without else "fitted"
        line, _ = replay_line(name, eps, fit.car, how)
        report.append(line)
        print(line)
    for name, car in held_out.items():
        line, _ = replay_line(name, sets[name], car, "held out: fitted on the other logs")
        report.append(line)
        print(line)
    for n, v in zip(fit.names, fit.values, strict=True):
        print(f"  {n:32s} {v:10.4f} {PARAMETERS[n][2]}")
    if not args.dry_run:
        command = "tools/fit_car_model.py " + " ".join(sys.argv[1:])
        write_module(args.simulator, fit.car, fitted, report, held_out, args.output, command)
        print(f"wrote {args.output}")


def refuse(message: str) -> NoReturn:
    """Stop on bad input: one sentence on stderr, exit code 2, nothing written."""
    print(message, file=sys.stderr)
    raise SystemExit(2)


def _or(value: float | None, default: float) -> float:
    return default if value is None else value


def _per_version(values: dict[str, float]) -> str:
    return ", ".join(f"version {v}: {w:g}" for v, w in values.items())


def _assignment(text: str) -> tuple[str, float]:
    name, _, value = text.partition("=")
    try:
        return _known(name), float(value)
    except ValueError:
        refuse(f"{text!r} is not NAME=NUMBER; write it as e.g. max_braking=4.4.")


def _known(name: str) -> str:
    if name not in PARAMETERS:
        refuse(f"unknown constant {name!r}; use one of {', '.join(PARAMETERS)}.")
    return name


if __name__ == "__main__":
    main()
