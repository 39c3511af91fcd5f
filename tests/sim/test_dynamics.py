"""The car model: speed lag, steering servo, grip limit, geometry."""

from __future__ import annotations

import math

import pytest

from drx.sim.dynamics import (
    CarParams,
    CarState,
    G,
    rear_axle_from_reference,
    reference_point,
    step_car,
    wheel_positions,
)

P = CarParams()


def test_deepracer_geometry() -> None:
    assert (P.wheelbase, P.track_width, P.reference_offset, P.rate_hz) == (0.164, 0.162, 0.14, 15.0)
    wheels = wheel_positions(0.0, 0.0, math.pi / 2, P)  # facing +y
    (rl, rr, fl, fr) = wheels
    assert rl == pytest.approx((-0.081, 0.0)) and rr == pytest.approx((0.081, 0.0))
    assert fl == pytest.approx((-0.081, 0.164)) and fr == pytest.approx((0.081, 0.164))
    rx, ry = rear_axle_from_reference(1.0, 2.0, 0.3, P)
    assert reference_point(CarState(rx, ry, 0.3), P) == pytest.approx((1.0, 2.0))


def test_speed_follows_a_first_order_lag() -> None:
    car = CarState(0.0, 0.0, 0.0)
    speeds = []
    for _ in range(30):
        step_car(car, 1.0, 0.0, P)
        speeds.append(car.speed)
    assert all(b > a for a, b in zip(speeds, speeds[1:], strict=False))
    dt = 1 / 15
    assert speeds[0] == pytest.approx(1 - math.exp(-dt / P.speed_time_constant))
    assert speeds[-1] == pytest.approx(1.0, abs=1e-3)
    assert car.y == pytest.approx(0.0) and car.x > 1.0
    car.speed = 4.0
    step_car(car, 0.5, 0.0, P)
    assert 4.0 - car.speed <= P.max_braking * dt + 1e-9  # braking is bounded


def test_steering_servo_is_rate_limited() -> None:
    car = CarState(0.0, 0.0, 0.0, speed=1.0)
    step_car(car, 1.0, math.radians(30), P)
    assert car.steering == pytest.approx(P.steering_rate / 15)
    for _ in range(5):
        step_car(car, 1.0, math.radians(30), P)
    assert car.steering == pytest.approx(math.radians(30))
    step_car(car, 1.0, math.radians(90), P)
    assert car.steering == pytest.approx(P.max_steering)  # mechanical limit


def test_slow_car_follows_the_steered_arc() -> None:
    car = CarState(0.0, 0.0, 0.0, speed=1.0, steering=math.radians(20))
    for _ in range(15):
        step_car(car, 1.0, math.radians(20), P)
    radius = P.wheelbase / math.tan(math.radians(20))
    # The rear axle stays on the circle of that radius around (0, radius).
    assert math.hypot(car.x, car.y - radius) == pytest.approx(radius, rel=0.01)
    assert not car.sliding


def test_fast_car_is_limited_by_grip() -> None:
    car = CarState(0.0, 0.0, 0.0, speed=4.0, steering=math.radians(30))
    yaws = []
    for _ in range(5):
        before = car.yaw
        step_car(car, 4.0, math.radians(30), P)
        yaws.append(car.yaw - before)
    assert car.sliding
    # Yaw rate = a_max / v instead of v tan(delta) / L.
    assert yaws[-1] * 15 == pytest.approx(P.grip * G / 4.0, rel=0.01)
    assert yaws[-1] * 15 < 0.3 * 4.0 * math.tan(math.radians(30)) / P.wheelbase
