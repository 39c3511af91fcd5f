"""How each DeepRacer simulator turns the agent's command into joint motion (the referee's laws).

Runs under ``.venv-dart`` only; never imports drx. Both versions: the steering command (radians) goes
to both hinges alike (parallel steering) and the speed command to every wheel as ``speed / 0.035``
rad/s (deepracer-simapp ``markov/agent_ctrl/rollout_agent_ctrl.py`` ``_update_speed`` /
``_update_steering``, ``markov/agent_ctrl/utils.py`` ``get_wheel_radius``).

- **Version 6** (:class:`Simapp6Control`): ``JointGroupVelocityController`` and
  ``JointGroupPositionController`` forward the commands (``config/racecar_control_kinematics.yaml``;
  their ``pid:`` blocks are not read by these controller types) to gz_ros2_control (jazzy,
  ``gz_system.cpp``): a velocity command becomes ``JointVelocityCmd``, which gz-physics' dartsim
  plugin applies as a DART ``SERVO`` actuator (the joint reaches the velocity within the step if the
  URDF's effort limit, 10 N m, allows); a position command becomes the velocity
  ``-k (theta - theta_cmd) * update_rate`` with ``k`` = ``position_proportional_gain`` (0.1 by
  default, ``gz_ros2_control_plugin.cpp``; simapp sets none) and ``update_rate`` 60 (the controller
  manager's). ``read()``, so ``theta``, and the controllers' ``update()`` run in ``PostUpdate`` once
  ``sim_period >= 1/60 s`` (every 17 ms of 1 ms steps); ``write()`` runs every physics step with the
  values of the last update.
- **Version 5** (:class:`Simapp5Control`): gazebo_ros_control's ``DefaultRobotHWSim`` (noetic,
  ``default_robot_hw_sim.cpp``) with ``gazebo_ros_control/pid_gains`` (``config/
  racecar_control_kinematics.yaml``), every 1 ms physics step (no ``controlPeriod`` in
  ``racecar.gazebo``): wheels ``VELOCITY_PID`` (P 1.0 rear, 0.5 front), effort
  ``clamp(P (omega_cmd - omega), +-10)``; hinges ``POSITION_PID`` (P 1.0, D 0.5): the command first
  passes joint_limits_interface's ``PositionJointSaturationHandle`` (the URDF's 100 rad/s: at most
  0.1 rad from the last command per 1 ms), then ``effort = clamp(P e + D (e - e_prev) / dt, +-10)``
  on the error ``e`` (control_toolbox ``Pid::computeCommand(error, dt)``).
"""

from __future__ import annotations

import dartpy as dart
from car import HINGES, WHEELS

COMMAND_RADIUS = 0.035  # [m] simapp divides the speed command by it
WHEEL_SPEED_LIMIT = 100.0  # [rad/s] the URDF's joint velocity limit
EFFORT_LIMIT = 10.0  # [N m] the URDF's joint effort limit


class Control:
    """A version's controllers on one skeleton: ``command`` takes the agent's action, ``before_step``
    runs before each 1 ms physics step at simulated time ``t_ms``."""

    def __init__(self, skel: dart.dynamics.Skeleton) -> None:
        self.wheels = [skel.getJoint(f"{w}_joint") for w in WHEELS]
        self.hinges = [skel.getJoint(f"{h}_joint") for h in HINGES]
        self.speed_cmd = 0.0
        self.steer_cmd = 0.0

    def command(self, speed: float, steering: float) -> None:
        """The agent's action: speed [m/s] and steering [rad], clipped as simapp clips them."""
        self.speed_cmd = min(max(speed, 0.1), 4.0) if speed > 0.0 else 0.0
        self.steer_cmd = min(max(steering, -0.5236), 0.5236)

    def wheel_rate(self) -> float:
        """Each wheel's commanded rad/s, held to the joints' velocity limit."""
        return min(self.speed_cmd / COMMAND_RADIUS, WHEEL_SPEED_LIMIT)

    def reset(self, steering: float, phase_ms: int) -> None:
        """Controller state for a car whose hinges stand at ``steering`` [rad] under the last command,
        ``phase_ms`` into the controllers' period (version 6)."""
        raise NotImplementedError

    def before_step(self, t_ms: int) -> None:
        raise NotImplementedError


class Simapp6Control(Control):
    """gz_ros2_control's forward velocity servo and proportional position law at 60 Hz."""

    GAIN = 0.1  # position_proportional_gain default
    RATE = 60.0  # [Hz] controller manager update_rate
    PERIOD_MS = 17  # sim_period >= 1/60 s on 1 ms ticks

    def __init__(self, skel: dart.dynamics.Skeleton) -> None:
        super().__init__(skel)
        for j in self.wheels + self.hinges:
            j.setActuatorType(dart.dynamics.ActuatorType.SERVO)
            j.setForceLowerLimit(0, -EFFORT_LIMIT)
            j.setForceUpperLimit(0, EFFORT_LIMIT)
        self.last_update = -self.PERIOD_MS
        self.hinge_rate = [0.0, 0.0]
        self.wheel_cmd = 0.0

    def reset(self, steering: float, phase_ms: int) -> None:
        self.last_update = -(phase_ms % self.PERIOD_MS)
        self.hinge_rate = [-self.GAIN * (steering - self.steer_cmd) * self.RATE] * 2
        self.wheel_cmd = self.wheel_rate()

    def before_step(self, t_ms: int) -> None:
        if t_ms - self.last_update >= self.PERIOD_MS:  # read() + update() of the last PostUpdate
            self.last_update = t_ms
            self.wheel_cmd = self.wheel_rate()
            self.hinge_rate = [
                -self.GAIN * (h.getPosition(0) - self.steer_cmd) * self.RATE for h in self.hinges
            ]
        for w in self.wheels:  # write(): every step, the values of the last update
            w.setCommand(0, self.wheel_cmd)
        for h, rate in zip(self.hinges, self.hinge_rate, strict=True):
            h.setCommand(0, rate)


class Simapp5Control(Control):
    """gazebo_ros_control's PID effort laws at 1 kHz."""

    WHEEL_P = (1.0, 1.0, 0.5, 0.5)  # rear, rear, front, front
    HINGE_P, HINGE_D = 1.0, 0.5
    DT = 0.001  # [s]
    RAMP = WHEEL_SPEED_LIMIT * DT  # [rad] PositionJointSaturationHandle: the hinges' 100 rad/s

    def __init__(self, skel: dart.dynamics.Skeleton) -> None:
        super().__init__(skel)
        for j in self.wheels + self.hinges:
            j.setActuatorType(dart.dynamics.ActuatorType.FORCE)
        self.sat_cmd = [0.0, 0.0]
        self.prev_error = [0.0, 0.0]

    def reset(self, steering: float, phase_ms: int) -> None:
        self.sat_cmd = [self.steer_cmd, self.steer_cmd]  # the last command, reached by the ramp
        self.prev_error = [self.steer_cmd - steering] * 2

    def before_step(self, t_ms: int) -> None:
        target = self.wheel_rate()
        for w, p in zip(self.wheels, self.WHEEL_P, strict=True):
            w.setForce(0, _clamp(p * (target - w.getVelocity(0)), EFFORT_LIMIT))
        for i, h in enumerate(self.hinges):
            last = self.sat_cmd[i]
            cmd = min(max(self.steer_cmd, last - self.RAMP, -1.0), last + self.RAMP, 1.0)
            self.sat_cmd[i] = cmd
            error = cmd - h.getPosition(0)
            effort = self.HINGE_P * error + self.HINGE_D * (error - self.prev_error[i]) / self.DT
            self.prev_error[i] = error
            h.setForce(0, _clamp(effort, EFFORT_LIMIT))


def _clamp(x: float, limit: float) -> float:
    return limit if x > limit else (-limit if x < -limit else x)


CONTROLS = {"5": Simapp5Control, "6": Simapp6Control}
