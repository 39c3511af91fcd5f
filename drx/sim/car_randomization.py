"""Domain randomisation over the car: a training episode's car drawn between simulator 5's and 6's.

A model exported from drx races on DeepRacer simulator 6 (DeepRacer on AWS, deepracer-for-cloud
6.x) or 5 (deepracer-for-cloud 5.x); the two drive differently (``docs/DYNAMICS.md``, "Simulator
6"). Trained on one car alone, a policy learns that car's steering lag and grip. With
``car_randomization`` each training episode draws its own car (:meth:`CarRandomizer.draw`), so the
policy has to hold on any car in the range. Each range comes from the sources of the two cars:

- **steering law and lag, and everything else the two fits differ in**: every fitted constant of
  the episode's car is ``(1 - t) * v5 + t * v6`` with ``t`` uniform in [0, 1]: simapp 5's PID hinge
  (fitted to its logs, :mod:`drx.sim.car_calibration`) to simapp 6's 60 Hz servo with its 0.16 s lag
  (fitted to the DART referee);
- **mass**: the car weighs 6.56 kg in simapp 5 and 7.54 kg in simapp 6 (the URDFs' inertials,
  ``../shared/deepracer-car``), 15 % apart; the yaw and speed lags, which grow with the car's
  inertia, are scaled by a further factor uniform in [0.93, 1.07] (half that spread either side);
- **grip**: both cars' tyres have friction 0.5 (``racecar.gazebo``), but the lateral acceleration
  they hold at speed differs with the engine: 3.9-4.1 m/s^2 in simapp 5's logs, 4.1-4.5 m/s^2 in
  DART (the referee's held turns at 2-3 m/s); ``lateral_accel_max`` is scaled by a factor uniform
  in [0.9, 1.1];
- **speed gain**: simapp divides the speed command by a wheel radius of 0.035 m while the wheels'
  collision meshes are 0.0360 (rear) and 0.0362 m (front): the ground speed is 1.029 times the
  command in DART, 0.93-1.0 times in simapp 5's logs; ``speed_gain`` is scaled by a factor uniform in
  [0.97, 1.03].

The geometry, limits and step timing are the same in both versions and are not varied.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from drx.sim.dynamics import CarParams

# The constants the two versions' fits set (the rest is geometry and limits, the same in both).
FITTED = (
    "command_delay", "steering_time_constant", "steering_time_constant_per_speed", "steering_gain",
    "steering_saturation", "steering_speed_k1", "steering_speed_k2", "lateral_accel_max", "grip_slip",
    "tyre_shape", "yaw_lag_share", "yaw_time_constant", "yaw_time_constant_per_speed", "pivot_offset",
    "speed_gain", "speed_offset", "speed_time_constant", "speed_time_constant_per_speed",
    "max_acceleration", "max_braking",
)  # fmt: skip
MASS_SPREAD = (0.93, 1.07)  # x the yaw and speed lags (6.56 vs 7.54 kg: 15 % apart, half either side)
GRIP_SPREAD = (0.9, 1.1)  # x lateral_accel_max (3.9-4.1 m/s^2 in simapp 5's logs, 4.1-4.5 in DART)
SPEED_SPREAD = (0.97, 1.03)  # x speed_gain (wheel meshes 0.0360-0.0362 m against the 0.035 m command)


@dataclass(frozen=True)
class CarRandomizer:
    """Draws a car per episode between ``a`` and ``b`` (simulator 5's and 6's cars by default)."""

    a: CarParams
    b: CarParams

    @classmethod
    def between_simulators(cls) -> CarRandomizer:
        """Between the cars of DeepRacer simulators 5 and 6."""
        return cls(CarParams.for_simulator("5"), CarParams.for_simulator("6"))

    def draw(self, rng: np.random.Generator) -> CarParams:
        """One episode's car (see the module docstring for the ranges)."""
        t = float(rng.uniform(0.0, 1.0))
        mass = float(rng.uniform(*MASS_SPREAD))
        grip = float(rng.uniform(*GRIP_SPREAD))
        speed = float(rng.uniform(*SPEED_SPREAD))
        values = {n: (1.0 - t) * getattr(self.a, n) + t * getattr(self.b, n) for n in FITTED}
        for name in ("yaw_time_constant", "yaw_time_constant_per_speed", "speed_time_constant",
                     "speed_time_constant_per_speed"):  # fmt: skip
            values[name] *= mass
        values["lateral_accel_max"] *= grip
        values["speed_gain"] *= speed
        return self.a.with_values(**values)

