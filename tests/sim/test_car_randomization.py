"""Car randomization: every training episode draws a car between simulator 5's and 6's, within the
cited ranges; evaluations drive the model's own car."""

from __future__ import annotations

import numpy as np

from drx.sim.car_randomization import FITTED, GRIP_SPREAD, SPEED_SPREAD, CarRandomizer
from drx.sim.dynamics import CarParams
from drx.sim.env import DeepRacerEnv


def test_each_draw_lies_between_the_two_cars_within_the_spreads() -> None:
    a, b = CarParams.for_simulator("5"), CarParams.for_simulator("6")
    randomizer = CarRandomizer(a, b)
    rng = np.random.default_rng(1)
    cars = [randomizer.draw(rng) for _ in range(200)]
    for name in ("command_delay", "steering_time_constant", "steering_gain", "pivot_offset"):
        values = np.array([getattr(c, name) for c in cars])
        lo, hi = sorted((getattr(a, name), getattr(b, name)))
        assert lo - 1e-12 <= values.min() and values.max() <= hi + 1e-12
        if hi > lo:
            assert values.max() - values.min() > 0.5 * (hi - lo)  # the whole range is used
    grip = np.array([c.lateral_accel_max for c in cars])
    lo, hi = sorted((a.lateral_accel_max, b.lateral_accel_max))
    assert grip.min() >= lo * GRIP_SPREAD[0] - 1e-9 and grip.max() <= hi * GRIP_SPREAD[1] + 1e-9
    speed = np.array([c.speed_gain for c in cars])
    lo, hi = sorted((a.speed_gain, b.speed_gain))
    assert speed.min() >= lo * SPEED_SPREAD[0] - 1e-9 and speed.max() <= hi * SPEED_SPREAD[1] + 1e-9
    for c in cars:  # geometry and limits are the same car's
        limits = (c.wheelbase, c.max_speed, c.wheel_speed_limit)
        assert limits == (a.wheelbase, a.max_speed, a.wheel_speed_limit)
    assert set(FITTED) < {f for f in CarParams.__dataclass_fields__}


def test_training_episodes_drive_drawn_cars_and_evaluations_the_models_own() -> None:
    own = CarParams.for_simulator("6")
    train = DeepRacerEnv(track="oval", car=own, car_randomization=True, deterministic=True)
    seen = set()
    for seed in range(4):
        train.reset(seed=seed)
        seen.add(train.car.steering_gain)
        train.step(train.action_space.sample())
    assert len(seen) == 4 and own.steering_gain not in seen
    train.reset(seed=0)
    first = train.car
    train.reset(seed=0)
    assert train.car == first  # seeded: the same episode draws the same car
    evaluation = DeepRacerEnv(track="oval", car=own, car_randomization=True, mode="evaluation")
    evaluation.reset(seed=0)
    assert evaluation.car == own

