"""The car model: command delay, speed lag, speed-dependent steering, grip, side slip, geometry."""

from __future__ import annotations

import math

import numpy as np
import pytest

from drx.sim.dynamics import (
    CarParams,
    CarState,
    rear_axle_from_origin,
    rear_axle_from_reference,
    reference_point,
    steady_curvature,
    steady_state,
    steering_for_curvature,
    step_car,
    wheel_positions,
)

P = CarParams()
DT = 1 / 15


def test_deepracer_geometry() -> None:
    assert (P.wheelbase, P.track_width, P.rate_hz) == (0.164, 0.162, 15.0)
    # params (x, y) is 0.14 m ahead of the origin, which is the middle of the wheelbase
    assert P.origin_offset == pytest.approx(P.wheelbase / 2)
    assert P.reference_offset == pytest.approx(0.082 + 0.14)
    wheels = wheel_positions(0.0, 0.0, math.pi / 2, P)  # facing +y
    (rl, rr, fl, fr) = wheels
    assert rl == pytest.approx((-0.081, 0.0)) and rr == pytest.approx((0.081, 0.0))
    assert fl == pytest.approx((-0.081, 0.164)) and fr == pytest.approx((0.081, 0.164))
    rx, ry = rear_axle_from_reference(1.0, 2.0, 0.3, P)
    assert reference_point(CarState(rx, ry, 0.3), P) == pytest.approx((1.0, 2.0))
    ox, oy = rear_axle_from_origin(1.0, 2.0, 0.0, P)
    assert (ox, oy) == pytest.approx((1.0 - 0.082, 2.0))


def test_a_command_acts_after_the_delay() -> None:
    moved = {}
    for delay in (0.0, 0.5, 1.0):
        car = CarState(0.0, 0.0, 0.0)
        step_car(car, 2.0, 0.0, P.with_values(command_delay=delay))
        moved[delay] = car.x
    assert moved[1.0] == pytest.approx(0.0)  # one step late: nothing yet
    assert 0.0 < moved[0.5] < moved[0.0]


def test_speed_settles_at_command_plus_offset_within_the_motor_limits() -> None:
    car = CarState(0.0, 0.0, 0.0)
    speeds = []
    for _ in range(60):
        step_car(car, 1.0, 0.0, P)
        speeds.append(car.speed)
    assert all(b >= a for a, b in zip(speeds, speeds[1:], strict=False))
    assert speeds[-1] == pytest.approx(P.steady_speed(1.0), abs=1e-3)
    gains = [b - a for a, b in zip([0.0, *speeds], speeds, strict=False)]
    assert max(gains) <= P.max_acceleration * DT + 1e-9
    assert car.y == pytest.approx(0.0) and car.x > 2.0
    fast = CarState(0.0, 0.0, 0.0, speed=4.0)
    step_car(fast, 0.5, 0.0, P.with_values(command_delay=0.0))
    assert 4.0 - fast.speed <= P.max_braking * DT + 1e-9  # braking is bounded


def test_high_speed_takes_most_of_a_second() -> None:
    """DeepRacer's car reaches 1 m/s quickly but 4 m/s only after most of a second."""

    def time_to(fraction: float, command: float) -> float:
        car = CarState(0.0, 0.0, 0.0)
        for i in range(200):
            step_car(car, command, 0.0, P)
            if car.speed >= fraction * P.steady_speed(command):
                return (i + 1) * DT
        return math.inf

    assert time_to(0.9, 4.0) > 1.5 * time_to(0.9, 1.0)
    assert time_to(0.9, 4.0) > 0.75


@pytest.mark.parametrize("delay", [1.5, P.command_delay])
def test_steering_follows_the_command_after_the_delay(delay: float) -> None:
    p = P.with_values(command_delay=delay, steering_time_constant=0.1)
    car = CarState(0.0, 0.0, 0.0, speed=1.0)
    angles = []
    for _ in range(30):
        step_car(car, 1.0, math.radians(30), p)
        angles.append(car.steering)
    assert all(b >= a for a, b in zip(angles, angles[1:], strict=False))
    whole = int(delay)
    if whole >= 1:
        assert angles[whole - 1] == 0.0  # nothing before the delay
    assert 0.0 < angles[whole] < math.radians(30) * 0.9  # then a lag
    assert angles[-1] == pytest.approx(math.radians(30), rel=1e-3)
    step_car(car, 1.0, math.radians(90), P)
    assert car.commands[-1][1] == pytest.approx(P.max_steering)  # commands are clipped to 30 deg


def _turning(speed: float, steer_deg: float, p: CarParams) -> tuple[float, CarState]:
    """Steady curvature [1/m] of the pivot's path after holding a command."""
    car = steady_state(speed, math.radians(steer_deg), p, seconds=4.0)
    yaw0 = car.yaw
    step_car(car, speed, math.radians(steer_deg), p)
    dyaw = (car.yaw - yaw0 + math.pi) % (2 * math.pi) - math.pi
    return dyaw / (car.speed * DT), car


@pytest.mark.parametrize("speed", [1.0, 2.0, 3.0])
def test_steering_shrinks_with_speed(speed: float) -> None:
    kappa, car = _turning(speed, 30.0, P)
    v = car.speed
    sat = P.steering_saturation
    reach = P.steering_gain * sat * math.tanh(math.tan(math.radians(30)) / sat) / P.wheelbase
    reach /= 1 + P.steering_speed_k1 * v + P.steering_speed_k2 * v * v
    load = reach * v * v / P.grip(v, speed)  # the wheels driven at the held command
    n = P.tyre_shape
    assert kappa == pytest.approx(reach / (1 + load**n) ** (1 / n), rel=0.02)
    assert kappa == pytest.approx(steady_curvature(math.radians(30), v, P), rel=0.02)
    bicycle = math.tan(math.radians(30)) / P.wheelbase
    assert kappa < 0.6 * bicycle  # DeepRacer's car turns far wider than an ideal bicycle


def test_slipping_wheels_lose_grip() -> None:
    """Driven faster than the car runs, the wheels slip and the tyres hold less in a bend: the same turn
    at the same speed is wider under a far higher speed command, and the throttle limit a driver gets
    from :meth:`CarParams.fastest_command` leaves exactly the grip the bend needs."""
    assert P.grip_slip > 0.0
    assert P.grip(2.0, 4.0) < P.grip(2.0, 2.1) < P.lateral_accel_max
    assert P.grip(2.0, 2.0) == pytest.approx(P.lateral_accel_max)

    def bend_after(command: float) -> float:
        car = steady_state(2.0, math.radians(30), P, seconds=3.0)
        for _ in range(2):
            step_car(car, command, math.radians(30), P)
        return car.curvature

    assert bend_after(4.0) < 0.8 * bend_after(2.0)
    need = 1.0  # [1/m] at 2 m/s: 4 m/s^2, beyond the grip at rest -> no slip allowed
    assert P.fastest_command(need, 2.0) == pytest.approx(2.0)
    gentle = 0.3  # [1/m] at 2 m/s: 1.2 m/s^2
    limit = P.fastest_command(gentle, 2.0)
    assert limit > 2.0
    assert P.grip(2.0, limit) == pytest.approx(gentle * 4.0, rel=1e-9)
    assert P.with_values(grip_slip=0.0).fastest_command(gentle, 2.0) == math.inf


def test_grip_caps_lateral_acceleration() -> None:
    """The tyres give what the steering asks while it is little, saturate smoothly, never exceed grip."""
    slippery = P.with_values(steering_gain=1.0, lateral_accel_max=3.0, steering_speed_k1=0.0,
                             steering_speed_k2=0.0, grip_slip=0.0)  # fmt: skip
    kappa, car = _turning(3.0, 30.0, slippery)
    assert car.sliding
    assert kappa * car.speed**2 == pytest.approx(3.0, rel=0.02)  # far past the limit: grip itself
    asked = math.tan(math.radians(30)) / slippery.wheelbase * car.speed**2
    assert kappa * car.speed**2 < asked
    gentle, calm = _turning(1.0, 2.0, slippery)
    assert not calm.sliding
    assert gentle == pytest.approx(math.tan(math.radians(2)) / slippery.wheelbase, rel=0.05)


def test_the_pivot_point_moves_along_the_heading() -> None:
    for pivot in (0.0, 0.1):
        p = P.with_values(pivot_offset=pivot)
        car = steady_state(1.0, math.radians(30), p)
        before = car.copy()
        step_car(car, 1.0, math.radians(30), p)
        # the pivot's displacement points along the mean heading (a chord of its circle)
        px0 = before.x + pivot * math.cos(before.yaw)
        py0 = before.y + pivot * math.sin(before.yaw)
        px1 = car.x + pivot * math.cos(car.yaw)
        py1 = car.y + pivot * math.sin(car.yaw)
        chord = math.atan2(py1 - py0, px1 - px0)
        mean_yaw = before.yaw + 0.5 * ((car.yaw - before.yaw + math.pi) % (2 * math.pi) - math.pi)
        assert chord == pytest.approx(mean_yaw, abs=1e-9)


def test_steering_for_curvature_inverts_the_model() -> None:
    for speed in (1.0, 2.0):
        want = 1.0 / 1.5  # a 1.5 m radius
        steer = steering_for_curvature(want, P.steady_speed(speed), P)
        kappa, car = _turning(speed, math.degrees(steer), P)
        if not car.sliding:
            assert kappa == pytest.approx(want, rel=0.03)


def test_a_moving_start_state_holds_its_motion() -> None:
    car = CarState.moving(0.0, 0.0, 0.0, 2.0, 0.0, P)
    step_car(car, (2.0 - P.speed_offset) / P.speed_gain, 0.0, P)
    assert car.speed == pytest.approx(2.0, abs=1e-6)
    assert car.x == pytest.approx(2.0 * DT, rel=1e-6)


def _bend_after(steps: int, speed: float, p: CarParams) -> float:
    """The path's curvature [1/m] ``steps`` steps after a 20 deg command hits a car going straight at
    ``speed``, as a share of its steady curvature."""
    car = CarState.moving(0.0, 0.0, 0.0, speed, 0.0, p)
    command = (speed - p.speed_offset) / p.speed_gain
    for _ in range(steps):
        yaw0 = car.yaw
        step_car(car, command, math.radians(20), p)
    bend = ((car.yaw - yaw0 + math.pi) % (2 * math.pi) - math.pi) / (car.speed * DT)
    return bend / steady_curvature(math.radians(20), car.speed, p)


def test_the_bend_builds_up_through_the_yaw_lag_slower_at_speed() -> None:
    p = P.with_values(yaw_lag_share=0.9, yaw_time_constant=0.05, yaw_time_constant_per_speed=0.05,
                      pivot_offset=0.0)  # fmt: skip
    assert _bend_after(3, 3.0, p) < _bend_after(3, 1.0, p) < 0.95  # still building, more slowly at speed
    assert _bend_after(45, 3.0, p) == pytest.approx(1.0, abs=0.01)  # then it holds the steady turn
    assert _bend_after(45, 1.0, p) == pytest.approx(1.0, abs=0.01)
    off = P.with_values(yaw_lag_share=0.0, command_delay=0.0, steering_time_constant=1e-6, pivot_offset=0.0)
    assert _bend_after(2, 3.0, off) == pytest.approx(1.0, abs=0.01)  # no lag: the bend is there at once


def test_a_moving_start_state_carries_its_steady_bend() -> None:
    car = CarState.moving(0.0, 0.0, 0.0, 2.0, math.radians(10), P)
    assert car.curvature == pytest.approx(steady_curvature(math.radians(10), 2.0, P))
    assert car.copy().curvature == car.curvature


def test_the_hinges_give_at_large_angles() -> None:
    """The effective steering saturates: 30 deg bends the path less than six times 5 deg does."""
    p = P.with_values(steering_saturation=0.4, lateral_accel_max=100.0)
    small, large = (steady_curvature(math.radians(a), 1.0, p) for a in (5.0, 30.0))
    assert large < 0.9 * small * math.tan(math.radians(30)) / math.tan(math.radians(5))
    assert steering_for_curvature(large, 1.0, p) == pytest.approx(math.radians(30), rel=1e-6)


@pytest.mark.parametrize("shape", [1.5, 2.5, 18.0])
def test_tyre_demand_inverts_the_tyre_response(shape: float) -> None:
    """What the tyres deliver rises with what is asked, never past grip, and ``tyre_demand`` finds what
    to ask for a share of grip (drivers steer by it)."""
    from drx.sim.dynamics import tyre_demand, tyre_response

    loads = np.linspace(0.01, 5.0, 200)
    delivered = np.array([x * tyre_response(x, shape) for x in loads])
    assert np.all(np.diff(delivered) > 0) and np.all(delivered < 1.0)
    assert tyre_response(0.0, shape) == 1.0 and tyre_response(-2.0, shape) == tyre_response(2.0, shape)
    for x, d in zip(loads, delivered, strict=True):
        if d < 0.999:  # drivers ask for at most 99.9 % of grip (steering_for_curvature)
            assert tyre_demand(d, shape) == pytest.approx(x, rel=1e-6)


def test_the_wheels_follow_no_command_above_their_speed_limit() -> None:
    """Simapp 5 drives the wheels through velocity controllers saturated at 100 rad/s (3.5 m/s on the
    0.035 m the command is divided by): a 4 m/s command drives the car as 3.5 does, in the step, the
    steady speed and the wheel slip; a car without the limit (simapp 4's) keeps the difference."""
    limited = P.with_values(wheel_speed_limit=3.5, command_delay=0.0)
    assert limited.command_ceiling == 3.5
    assert limited.steady_speed(4.0) == limited.steady_speed(3.5) > limited.steady_speed(3.0)

    def speed_after(car: CarParams, command: float) -> float:
        state = CarState(0.0, 0.0, 0.0, speed=2.0)
        for _ in range(20):
            step_car(state, command, 0.0, car)
        return state.speed

    assert speed_after(limited, 4.0) == speed_after(limited, 3.5)
    free = limited.with_values(wheel_speed_limit=4.0)
    assert speed_after(free, 4.0) > speed_after(free, 3.5)


def test_braking_in_a_bend_leaves_the_grip_the_bend_needs() -> None:
    """A command below the speed slips the wheels backwards and spends grip as throttle does:
    :meth:`CarParams.slowest_command` is the lowest command that leaves exactly the grip a bend needs,
    the speed itself when the bend asks for all of it, and 0 when grip does not fall with slip."""
    gentle = 0.3  # [1/m] at 2 m/s: 1.2 m/s^2
    floor = P.slowest_command(gentle, 2.0)
    assert 0.0 < floor < 2.0
    assert P.grip(2.0, floor) == pytest.approx(gentle * 4.0, rel=1e-9)
    assert P.grip(2.0, 0.5 * floor) < gentle * 4.0  # braking harder than that leaves too little
    assert P.slowest_command(1.0, 2.0) == pytest.approx(2.0)  # 4 m/s^2: no slip to spare
    assert P.with_values(grip_slip=0.0).slowest_command(gentle, 2.0) == 0.0
