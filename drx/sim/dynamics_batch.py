""":func:`drx.sim.dynamics.step_car` for many cars at once, in NumPy, for fitting the model.

The fitting script (``tools/fit_car_model.py``) replays tens of thousands of
logged windows hundreds of times; the scalar step is right for the env (one
car, microseconds) and this batched one for the fit (one array operation per
step for every window). Both follow the same equations; ``tests/sim/
test_dynamics_batch.py`` checks that they agree to 1e-9 on random states and
commands, and the fitting script reports its final figures with the scalar
replay (:mod:`drx.calibration.replay`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from drx.sim.dynamics import CarParams, slip_grip, tyre_response


@dataclass
class BatchState:
    """``n`` cars: arrays of shape ``(n,)``; ``commands`` ``(n, 3, 2)`` (speed, steering), newest last;
    ``curvature`` the lagging part of the bend (:class:`drx.sim.dynamics.CarState`), zeros when omitted."""

    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    speed: np.ndarray
    steering: np.ndarray
    commands: np.ndarray
    curvature: np.ndarray | None = None


def step_cars(state: BatchState, speed_cmd: np.ndarray, steering_cmd: np.ndarray, p: CarParams,
              dt: np.ndarray) -> None:  # fmt: skip
    """Advance every car by one step in place (see :func:`drx.sim.dynamics.step_car`)."""
    lim = p.max_steering
    steering_cmd = np.clip(steering_cmd, -lim, lim)
    speed_cmd = np.clip(speed_cmd, 0.0, p.command_ceiling)
    cmds = state.commands
    cmds[:, :-1] = cmds[:, 1:]
    cmds[:, -1, 0] = speed_cmd
    cmds[:, -1, 1] = steering_cmd
    n, f = p.delay_split
    new = cmds[:, -1 - n]
    old = cmds[:, -2 - n] if f > 0.0 else new
    delta0, v0 = state.steering, state.speed
    delta, v = delta0.copy(), v0.copy()
    for cmd, h in ((old, f * dt), (new, (1.0 - f) * dt)):
        active = h > 0.0
        target_v = np.where(cmd[:, 0] > 0.0, p.speed_gain * cmd[:, 0] + p.speed_offset, 0.0)
        tau_s = p.steering_time_constant + p.steering_time_constant_per_speed * v
        delta = np.where(active, cmd[:, 1] + (delta - cmd[:, 1]) * np.exp(-h / tau_s), delta)
        tau = p.speed_time_constant + p.speed_time_constant_per_speed * v
        dv = (target_v - v) * (1.0 - np.exp(-h / tau))
        dv = np.clip(dv, -p.max_braking * h, p.max_acceleration * h)
        v = np.where(active, v + dv, v)
    v_mid = 0.5 * (v0 + v)
    delta_mid = 0.5 * (delta0 + delta)
    sat = p.steering_saturation
    kappa = p.steering_gain * sat * np.tanh(np.tan(delta_mid) / sat) / (
        p.wheelbase * (1.0 + v_mid * (p.steering_speed_k1 + p.steering_speed_k2 * v_mid))
    )
    grip = slip_grip(p.lateral_accel_max, p.grip_slip, v_mid, new[:, 0])
    kappa = kappa * tyre_response(kappa * v_mid * v_mid / grip, p.tyre_shape)
    if p.yaw_lag_share > 0.0:
        tau_y = p.yaw_time_constant + p.yaw_time_constant_per_speed * v_mid
        e = np.exp(-dt / tau_y)
        k0 = (state.curvature if state.curvature is not None else 0.0) - kappa
        state.curvature = kappa + k0 * e
        kappa = kappa + p.yaw_lag_share * k0 * (1.0 - e) * tau_y / dt
    else:
        state.curvature = kappa
    yaw0 = state.yaw
    dyaw = v_mid * kappa * dt
    heading = yaw0 + 0.5 * dyaw
    dist = v_mid * dt
    po = p.pivot_offset
    yaw1 = yaw0 + dyaw
    state.x = state.x + po * (np.cos(yaw0) - np.cos(yaw1)) + dist * np.cos(heading)
    state.y = state.y + po * (np.sin(yaw0) - np.sin(yaw1)) + dist * np.sin(heading)
    state.yaw = (yaw1 + np.pi) % (2.0 * np.pi) - np.pi
    state.speed = v
    state.steering = delta
