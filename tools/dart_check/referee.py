"""The DART referee: DeepRacer's car as simapp describes it, driven by a version's controller laws.

Runs under ``.venv-dart`` only (``tools/dart_check/setup.sh``); DART is a check tool, never a drx
dependency, and this script never imports drx. drx's side (``drx/calibration/referee.py``) writes
the request and reads the answer.

    .venv-dart/bin/python tools/dart_check/referee.py --car-dir ../shared/deepracer-car \\
        --version 6 request.json answer.json

The request holds windows to replay open-loop: each starts with the car's origin (``base_link``, the
middle of the wheelbase, which simapp reports as the car's position) at ``pose`` = ``[x, y, yaw]``
[m, m, rad], moving forward at ``speed`` [m/s] and turning at ``yaw_rate`` [rad/s], its hinges at
``steering`` [rad], and drives ``commands`` (``[speed m/s, steering rad]``, one per agent step), each
for ``step_ms`` milliseconds (DeepRacer's 15 Hz step is 66-67 ms of 1 ms physics steps), after
``prior``, the command of the step before, with version 6's 60 Hz controllers ``control_phase_ms``
into their period. The answer
gives, per window and per agent step, the origin's ``[x, y, yaw]`` at the step's end, the mean hinge
angle and the origin's forward speed.

The world: the car of :mod:`car` on a flat floor (friction 0.5 at the tyres), gravity 9.81, 1 ms
steps (simapp's worlds: ``max_step_size`` 0.001), DART's ODE collision detector and Dantzig boxed LCP
solver as gz-physics' dartsim plugin runs them. The car is first let down onto its wheels at rest;
each window then starts from that settled height, roll and pitch.
Exit codes: 0 done, 2 bad input.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import dartpy as dart
import numpy as np
from car import WHEEL_CENTRE_HEIGHT, WHEEL_RADIUS, build_car, ground, total_mass
from controllers import CONTROLS, Control

PHYSICS_MS = 1  # [ms] simapp's max_step_size
SETTLE_MS = 400  # [ms] letting the car down onto its wheels


class Referee:
    """One car of ``version`` in a DART world, reusable across windows."""

    def __init__(self, car_dir: Path, version: str) -> None:
        self.version = version
        self.world = dart.simulation.World()
        self.world.setTimeStep(PHYSICS_MS / 1000.0)
        self.world.setGravity(np.array([0.0, 0.0, -9.81]))
        self.car = build_car(car_dir, version)
        self.world.addSkeleton(ground())
        self.world.addSkeleton(self.car)
        solver = self.world.getConstraintSolver()
        solver.setCollisionDetector(dart.collision.OdeCollisionDetector())
        self.control: Control = CONTROLS[version](self.car)
        self.root = self.car.getRootJoint()
        self.mass = total_mass(self.car)
        self._rest = self._settle()

    def _settle(self) -> np.ndarray:
        """The root's positions once the car rests on its wheels (height, roll, pitch kept)."""
        self.car.resetPositions()
        self.car.resetVelocities()
        self._place(0.0, 0.0, 0.0, WHEEL_RADIUS - WHEEL_CENTRE_HEIGHT + 0.002)
        self.control.command(0.0, 0.0)
        self.control.reset(0.0, 0)
        for t in range(SETTLE_MS):
            self.control.before_step(t)
            self.world.step()
        return np.array(self.car.getPositions())

    def _place(self, x: float, y: float, yaw: float, z: float, tilt: np.ndarray | None = None) -> None:
        tf = dart.math.Isometry3()
        rot = _rot_z(yaw) if tilt is None else _rot_z(yaw) @ tilt
        tf.set_rotation(rot)
        tf.set_translation(np.array([x, y, z]))
        q = np.array(self.car.getPositions())
        q[:6] = dart.dynamics.FreeJoint.convertToPositions(tf)
        self.car.setPositions(q)

    def drive(self, window: dict) -> dict:
        """Replay one window (see the module docstring)."""
        x, y, yaw = (float(v) for v in window["pose"])
        speed, yaw_rate = float(window["speed"]), float(window.get("yaw_rate", 0.0))
        steering = float(window.get("steering", 0.0))
        rest_tf = dart.dynamics.FreeJoint.convertToTransform(self._rest[:6])
        tilt = rest_tf.rotation()
        self.car.setPositions(self._rest)
        self.car.resetVelocities()
        self._place(x, y, yaw, float(rest_tf.translation()[2]), tilt)
        for h in self.control.hinges:
            h.setPosition(0, steering)
        omega = speed / WHEEL_RADIUS
        for w in self.control.wheels:
            w.setVelocity(0, omega)
        heading = np.array([math.cos(yaw), math.sin(yaw), 0.0])
        self.root.setLinearVelocity(speed * heading)
        self.root.setAngularVelocity(np.array([0.0, 0.0, yaw_rate]))
        commands = window["commands"]
        step_ms = window["step_ms"]
        if isinstance(step_ms, (int, float)):
            step_ms = [int(step_ms)] * len(commands)
        prior = window.get("prior") or (commands[0] if commands else [speed, steering])
        self.control.command(float(prior[0]), float(prior[1]))
        self.control.reset(steering, int(window.get("control_phase_ms", 0)))
        poses, hinges, speeds = [], [], []
        t = 0
        for (v_cmd, s_cmd), ms in zip(commands, step_ms, strict=True):
            self.control.command(float(v_cmd), float(s_cmd))
            for _ in range(int(ms)):
                self.control.before_step(t)
                self.world.step()
                t += PHYSICS_MS
            poses.append(self.origin_pose())
            hinges.append(float(np.mean([h.getPosition(0) for h in self.control.hinges])))
            speeds.append(self.forward_speed())
        return {"poses": poses, "hinge": hinges, "speed": speeds}

    def origin_pose(self) -> list[float]:
        """The car's origin (``base_link``) ``[x, y, yaw]`` in the world."""
        tf = self.car.getBodyNode("base_link").getWorldTransform()
        p = tf.translation()
        r = tf.rotation()
        return [float(p[0]), float(p[1]), math.atan2(float(r[1, 0]), float(r[0, 0]))]

    def forward_speed(self) -> float:
        """The origin's speed along its heading [m/s]."""
        body = self.car.getBodyNode("base_link")
        v = np.asarray(body.getLinearVelocity())
        r = body.getWorldTransform().rotation()
        return float(v @ r[:, 0])


def _rot_z(yaw: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--car-dir", type=Path, required=True, help="../shared/deepracer-car")
    parser.add_argument("--version", choices=sorted(CONTROLS), required=True)
    parser.add_argument("request", type=Path)
    parser.add_argument("answer", type=Path)
    args = parser.parse_args(argv)
    if not (args.car_dir / f"v{args.version}").is_dir():
        print(f"referee: {args.car_dir} holds no v{args.version}/ car; point --car-dir at deepracer-car")
        return 2
    try:
        request = json.loads(args.request.read_text())
        windows = request["windows"]
    except (OSError, ValueError, KeyError) as exc:
        print(f"referee: cannot read the request {args.request}: {exc}")
        return 2
    started = time.perf_counter()
    referee = Referee(args.car_dir, args.version)
    answers = [referee.drive(w) for w in windows]
    answer = {
        "version": args.version,
        "car_mass": referee.mass,
        "dartpy": dart.__version__,
        "seconds": time.perf_counter() - started,
        "windows": answers,
    }
    tmp = args.answer.with_suffix(args.answer.suffix + ".tmp")
    tmp.write_text(json.dumps(answer))
    tmp.replace(args.answer)
    return 0


if __name__ == "__main__":
    sys.exit(main())
