"""Which of drx's cars drives each DeepRacer simulator version, and why (issue 34: version 6).

drx fits a car per DeepRacer simulator version (``drx.sim.car_calibration.SIMULATORS``: 4 and 5).
DeepRacer on AWS, the self-hosted successor of the console, runs deepracer-simapp 6 (ROS 2) and
writes ``"version": 6`` into ``model_metadata.json`` (aws-solutions/deepracer-on-aws
``source/libs/lambda/src/workflow/constants/simulation.ts``, ``SIM_APP_VERSION = 6``, 61af778f).

**Version 6 drives the car differently from version 5**, read in deepracer-simapp's source
(tag ``v5.3.3``, 608b024b, against master 01f5f015, simapp 6.0.5 = DeepRacer on AWS 1.2.4):

- what stayed: the speed command ``speed / 0.035`` rad/s and the wheels' 100 rad/s limit (so
  3.5 m/s), the 10 N m effort limit, the tyres' mesh and friction (mu 0.5), the wheelbase and
  track, the 15 Hz camera and the pause-act-wait step loop (``markov/agent_ctrl/
  rollout_agent_ctrl.py``, ``urdf/deepracer/racecar.gazebo``, ``deepracer_racetrack_env.py``);
- what changed: Gazebo 11 with ODE became Gazebo Harmonic with DART (``launch/empty_world
  .launch.py``); the wheels' PID torque loop (``config/racecar_control_kinematics.yaml``, p 1.0 rear
  and 0.5 front) became a forward velocity command that DART's servo holds within 10 N m, and the
  steering's PID (p 1, d 0.5 at 1 kHz) a proportional velocity servo at 60 Hz (gz_ros2_control
  ``gz_system.cpp``: gain 0.1 x 60 Hz, a time constant near 0.16 s: a third of a step's steering
  change in one 1/15 s step); the camera links weigh 0.34 kg each and the body 0.3 kg, so the car is
  15 % heavier (``urdf/deepracer/deepracer_single_cam.urdf``) with 20 % more yaw inertia.

So version 6 needs a car of its own, fitted to version 6's logs as 4 and 5 were; no log of it has
been published yet (``../shared/deepracer-logs`` holds versions 4 and 5). Until one is, a version-6
log or model gets version 5's car, the nearest (same geometry, tyres, wheel limit and step), and drx
says so wherever it chooses it (``drx sim replay``, ``drx model import``). The launch files choose
the physics by ``version >= 5`` alike in both simulators (``launch/racecar.launch.py``), so a model
whose metadata says 5 gets version 6's physics on simapp 6: the number names the model, not the
simulator that drives it. drx writes ``"version": "5"`` into the folders it exports (its car is
version 5's), which both simulators read as a version-5 model.
"""

from __future__ import annotations

# Why a version without a car of its own gets the car it gets: said beside the choice.
NEAREST_CAR_REASON = {
    "6": (
        "simulator 6 (ROS 2: DART physics, servo-held wheels and steering, a 15 % heavier car) drives "
        "differently from 5, but no log of it has been fitted yet, so version 5's car, the nearest, "
        "stands in for it"
    ),
}


def nearest_car_reason(logged_major: int | str) -> str | None:
    """Why ``logged_major``'s nearest car stands in for it (``None`` when no reason is recorded)."""
    return NEAREST_CAR_REASON.get(str(logged_major))
