"""The fitting tool's batched step follows the env's scalar step exactly."""

from __future__ import annotations

import numpy as np
import pytest

from drx.sim.dynamics import CarParams, CarState, step_car
from drx.sim.dynamics_batch import BatchState, step_cars


@pytest.mark.parametrize("delay", [0.0, 0.4, 1.0, 1.7])
def test_batched_and_scalar_steps_agree(delay: float) -> None:
    rng = np.random.default_rng(5)
    p = CarParams().with_values(
        command_delay=delay, pivot_offset=0.05, lateral_accel_max=3.0, grip_slip=0.3, steering_saturation=0.4,
        yaw_lag_share=0.4, yaw_time_constant=0.1, yaw_time_constant_per_speed=0.05,
    )  # fmt: skip
    n = 64
    scalars = [
        CarState(float(x), float(y), float(h), float(v), float(d), [(float(c), float(s))] * 3, float(k))
        for x, y, h, v, d, c, s, k in zip(
            rng.normal(size=n), rng.normal(size=n), rng.uniform(-3, 3, n), rng.uniform(0, 4, n),
            rng.uniform(-0.5, 0.5, n), rng.uniform(0, 4, n), rng.uniform(-0.5, 0.5, n), rng.uniform(-2, 2, n),
            strict=True,
        )
    ]  # fmt: skip
    batch = BatchState(
        *(np.array([getattr(c, k) for c in scalars]) for k in ("x", "y", "yaw", "speed", "steering")),
        np.array([c.commands for c in scalars], dtype=float), np.array([c.curvature for c in scalars]),
    )  # fmt: skip
    for _ in range(20):
        speed = rng.uniform(0, 4.5, n)
        steer = rng.uniform(-0.6, 0.6, n)
        dt = rng.uniform(0.05, 0.09, n)
        for i, car in enumerate(scalars):
            step_car(car, float(speed[i]), float(steer[i]), p, float(dt[i]))
        step_cars(batch, speed, steer, p, dt)
    for name in ("x", "y", "yaw", "speed", "steering", "curvature"):
        assert getattr(batch, name) == pytest.approx([getattr(c, name) for c in scalars], abs=1e-9)
