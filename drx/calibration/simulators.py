"""Which of drx's cars drives each DeepRacer simulator version, and why.

drx has a car per DeepRacer simulator version (``drx.sim.car_calibration.SIMULATORS``): 4 and 5 fitted
to their published logs (``../shared/deepracer-logs``), 6 fitted to the DART referee
(``tools/dart_check``, :mod:`drx.calibration.referee_fit`), since no log of simapp 6 has been
published. DeepRacer on AWS, the self-hosted successor of the console, runs deepracer-simapp 6 (ROS 2)
and writes ``"version": 6`` into ``model_metadata.json`` (aws-solutions/deepracer-on-aws
``source/libs/lambda/src/workflow/constants/simulation.ts``, ``SIM_APP_VERSION = 6``, 61af778f);
deepracer-for-cloud pins simapp 6.0.4 since its 6.0 release.

Version 6 drives the car differently from version 5, read in deepracer-simapp's source (tag ``v5.3.3``,
608b024b, against master 01f5f015, simapp 6.0.5 = DeepRacer on AWS 1.2.4): DART instead of ODE,
servo-held wheels and a 60 Hz proportional steering law (a lag near 0.16 s) instead of PID torque
loops, and a car 15 % heavier (``docs/DYNAMICS.md``, "Simulator 6"). The launch files choose the
physics by ``version >= 5`` alike in both simulators (``launch/racecar.launch.py``): the number in
``model_metadata.json`` names the model, not the simulator that drives it, so an exported model
races on whatever simulator the venue runs. drx writes the version of the car the model trained on.

A log of a version drx has no car for (a simapp 3 log, a future 7) gets the nearest car drx has, and
drx says so wherever it chooses it (``drx sim replay``).
"""

from __future__ import annotations

# Why a version without a car of its own gets the car it gets: said beside the choice. Every version a
# published simapp has used since the console's logs (4, 5, 6) has a car now.
NEAREST_CAR_REASON: dict[str, str] = {}


def nearest_car_reason(logged_major: int | str) -> str | None:
    """Why ``logged_major``'s nearest car stands in for it (``None`` when no reason is recorded)."""
    return NEAREST_CAR_REASON.get(str(logged_major))
