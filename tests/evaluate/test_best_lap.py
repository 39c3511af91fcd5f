"""The best-lap solver: box QP, racing line, speed profile, and the lap on every real track."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from drx.errors import DrxError
from drx.evaluate.boxqp import solve_box_qp
from drx.evaluate.racing_line import (
    border_polyline,
    distance_to_polyline,
    inside_road,
    keep_clear,
    min_curvature_line,
)
from drx.evaluate.speed_profile import CRAWL, SpeedLimits, lap_time, speed_profile
from drx.evaluate.theoretical_lap import (
    LAP_LINE_CLEARANCE,
    best_lap,
    best_lap_on_line,
    car_limits,
    racing_line_waypoints,
)
from drx.evaluate.theoretical_lap_plot import draw_best_lap
from drx.sim.catalogue import SHIPPED_FOLDERS
from drx.sim.dynamics import CarParams, G
from drx.sim.track import Track
from drx.vehicle import Action, Vehicle

SHARED = SHIPPED_FOLDERS["deepracer"]  # DeepRacer's routes, as drx ships them
HALF_WIDTH = 0.5 * CarParams().track_width
FAST = Vehicle(name="fast", continuous=True, steering_range=(-30.0, 30.0), speed_range=(0.5, 4.0))


def ring(radius: float, width: float, n: int = 400) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A circular road (centre, inner, outer), counter-clockwise, with a closing duplicate."""
    a = np.linspace(0.0, 2 * math.pi, n + 1)
    unit = np.column_stack([np.cos(a), np.sin(a)])
    return radius * unit, (radius - width / 2) * unit, (radius + width / 2) * unit


def test_box_qp_matches_projected_gradient() -> None:
    rng = np.random.default_rng(1)
    a = rng.normal(size=(15, 25))
    h = a.T @ a + 1e-3 * np.eye(25)
    g = rng.normal(size=25) * 3
    lo, hi = -rng.uniform(0, 1, 25), rng.uniform(0, 1, 25)
    res = solve_box_qp(h, g, lo, hi)
    x = np.zeros(25)
    step = 1.0 / np.linalg.eigvalsh(h).max()
    for _ in range(50_000):
        x = np.clip(x - step * (h @ x + g), lo, hi)
    assert res.converged
    assert np.allclose(res.x, x, atol=1e-6)
    assert np.all(res.x >= lo) and np.all(res.x <= hi)


@pytest.mark.parametrize("radius", [0.8, 1.5])
def test_circle_lap_time_is_grip_limited(radius: float) -> None:
    """A circular road as wide as the car: the line is the circle, the lap 2 pi R / sqrt(a R)."""
    center, inner, outer = ring(radius, 2 * HALF_WIDTH + 1e-3)
    line = min_curvature_line(center, inner, outer, True, HALF_WIDTH)
    assert np.allclose(np.linalg.norm(line.points, axis=1), radius, atol=1e-3)
    grip = 0.9 * G
    limits = SpeedLimits(top_speed=4.0, lateral_accel=grip, max_acceleration=6.0, max_braking=8.0)
    assert math.sqrt(grip * radius) < limits.top_speed
    best = best_lap_on_line(line, limits)
    assert best.flying_lap_time == pytest.approx(2 * math.pi * radius / math.sqrt(grip * radius), rel=1e-3)
    assert best.lap_time > best.flying_lap_time  # the timed lap starts from rest
    # from rest at the line, then at the grip speed round the rest of the circle
    assert best.speeds[0] == 0.0
    half = best.speeds[len(best.speeds) // 2 :]
    assert half == pytest.approx(np.full(len(half), math.sqrt(grip * radius)), rel=1e-2)


def test_wide_circle_line_is_a_circle_inside_the_road() -> None:
    """On a wider circular road the line is still a circle (of the radius the solver picks) with that lap."""
    center, inner, outer = ring(1.5, 0.6)
    line = min_curvature_line(center, inner, outer, True, HALF_WIDTH)
    radii = np.linalg.norm(line.points, axis=1)
    r = float(np.mean(radii))
    assert np.ptp(radii) < 1e-3
    assert 1.5 - 0.3 + HALF_WIDTH - 1e-4 <= r <= 1.5 + 0.3 - HALF_WIDTH + 1e-4
    grip = 0.9 * G
    limits = SpeedLimits(top_speed=4.0, lateral_accel=grip, max_acceleration=6.0, max_braking=8.0)
    assert best_lap_on_line(line, limits).flying_lap_time == pytest.approx(
        2 * math.pi * math.sqrt(r / grip), rel=1e-3
    )


def test_circle_above_top_speed_runs_at_top_speed() -> None:
    center, inner, outer = ring(5.0, 0.6)
    line = min_curvature_line(center, inner, outer, True, HALF_WIDTH)
    limits = SpeedLimits(top_speed=1.0, lateral_accel=0.9 * G, max_acceleration=6.0, max_braking=8.0)
    assert best_lap_on_line(line, limits).flying_lap_time == pytest.approx(line.length / 1.0, rel=1e-9)


def test_speed_profile_straight_from_rest_matches_kinematics() -> None:
    """Constant acceleration a from rest over L: t = sqrt(2 L / a) while below top speed."""
    ds = np.full(100, 0.01)
    limits = SpeedLimits(top_speed=10.0, lateral_accel=9.0, max_acceleration=2.0, max_braking=8.0)
    v = speed_profile(ds, np.zeros(101), False, limits)
    assert v[-1] == pytest.approx(math.sqrt(2 * 2.0 * 1.0), rel=1e-6)
    assert lap_time(ds, v, False) == pytest.approx(math.sqrt(2 * 1.0 / 2.0), rel=1e-3)


def test_speed_profile_brakes_before_a_bend() -> None:
    n = 300
    kappa = np.zeros(n)
    kappa[200:220] = 2.0  # a tight bend after 2 m of straight
    limits = SpeedLimits(top_speed=4.0, lateral_accel=0.9 * G, max_acceleration=6.0, max_braking=8.0)
    v = speed_profile(np.full(n, 0.01), kappa, True, limits)
    corner = math.sqrt(0.9 * G / 2.0)
    assert v[200:220] == pytest.approx(np.full(20, corner))
    # braking at 8 m/s^2: 0.2 m before the bend the car is at most sqrt(corner^2 + 2*8*0.2)
    assert v[180] <= math.sqrt(corner**2 + 2 * 8.0 * 0.2) + 1e-9
    assert v[100] > v[180]


def test_car_limits_follow_the_car_and_the_simulator() -> None:
    slow = Vehicle(name="slow", actions=(Action(-20.0, 0.5), Action(20.0, 1.5)))
    limits = car_limits(slow)
    p = CarParams()
    # the calibrated car settles at its own speed for each command
    assert limits.top_speed == pytest.approx(p.steady_speed(1.5))
    assert limits.min_command == pytest.approx(p.steady_speed(0.5))
    assert limits.lateral_accel == pytest.approx(p.lateral_accel_max)
    assert limits.max_curvature == pytest.approx(math.tan(math.radians(20.0)) / p.wheelbase)
    assert (limits.steering_k1, limits.steering_k2) == (p.steering_speed_k1, p.steering_speed_k2)
    assert limits.time_constant_per_speed == p.speed_time_constant_per_speed
    for v in (0.5, 1.0, 2.0, 3.5):  # the tyres' limit in a steady bend, as the car model has it
        assert float(limits.grip(np.array(v))) == pytest.approx(p.grip(v), rel=1e-12)


def test_slipping_wheels_hold_back_the_acceleration_in_a_bend() -> None:
    """Full throttle in a bend would spin the wheels and lose the grip the bend needs (the car model's
    :meth:`~drx.sim.dynamics.CarParams.grip`): the solver accelerates less there, and a lap is no faster
    than with grip that does not depend on slip."""
    p = CarParams()
    assert p.grip_slip > 0.0
    limits = car_limits(FAST, p)
    assert limits.accel_in_bend(2.0, 0.0) == limits.accel(2.0)
    # the tighter the bend, the less slip its grip leaves: 2.8 m/s^2 of 3.6 at 0.7 /m, 2 m/s
    assert limits.accel_in_bend(2.0, 0.8) < limits.accel_in_bend(2.0, 0.7) < limits.accel(2.0)
    assert limits.accel_in_bend(2.0, 1.0) < 0.1 * limits.accel(2.0)  # 4 m/s^2 at 2 m/s: beyond grip
    center, inner, outer = ring(1.5, 1.0)
    track = Track("ring", center, inner, outer)
    slipping = best_lap(track, FAST, p).lap_time
    assert slipping > best_lap(track, FAST, p.with_values(grip_slip=0.0)).lap_time


def test_cornering_speed_follows_the_car_models_steering() -> None:
    """The fastest speed through a bend is where the car model's full lock just holds it."""
    from drx.sim.dynamics import steady_state

    limits = car_limits(FAST)
    p = CarParams()
    for radius in (1.0, 2.0, 4.0):
        v = float(limits.cornering_speeds(np.array([1.0 / radius]))[0])
        if v >= limits.top_speed:
            continue
        # the simulated car holding full lock at (just under) that speed turns on that radius
        command = (v - p.speed_offset) / p.speed_gain
        car = steady_state(command, math.radians(30.0), p, seconds=4.0)
        yaw0 = car.yaw
        from drx.sim.dynamics import step_car

        step_car(car, command, math.radians(30.0), p)
        kappa = ((car.yaw - yaw0 + math.pi) % (2 * math.pi) - math.pi) / (car.speed / 15)
        assert 1.0 / kappa == pytest.approx(radius, rel=0.03)


def test_turning_curvature_is_the_car_models_steady_turn() -> None:
    """The solver's full-lock turn at each speed is the car model's steady curvature, and
    cornering_speeds inverts it."""
    from drx.sim.dynamics import steady_curvature

    limits = car_limits(FAST)
    p = CarParams()
    speeds = np.array([1.5, 2.0, 3.0])
    assert speeds.min() > CRAWL * limits.min_command
    expected = [steady_curvature(math.radians(30.0), v, p) for v in speeds]
    assert limits.turning_curvature(speeds) == pytest.approx(expected, rel=1e-9)
    back = limits.cornering_speeds(np.array(expected))
    assert limits.turning_curvature(back) == pytest.approx(expected, rel=1e-6)
    assert np.all(back >= speeds - 1e-6)  # the fastest speed with that turn
    # tighter than full lock at rest: a crawl; gentler than full lock at top speed: the top speed
    assert limits.cornering_speeds(np.array([2 * limits.tightest_curvature]))[0] == pytest.approx(
        CRAWL * limits.min_command
    )
    assert limits.cornering_speeds(np.array([1e-6]))[0] == limits.top_speed


def test_a_car_that_cannot_steer_enough_is_refused() -> None:
    center, inner, outer = ring(0.5, 0.4)
    line = min_curvature_line(center, inner, outer, True, HALF_WIDTH)
    stiff = Vehicle(name="stiff", actions=(Action(-2.0, 1.0), Action(2.0, 1.0)))
    with pytest.raises(DrxError, match="steer"):
        best_lap_on_line(line, car_limits(stiff), track_name="ring", car_name="stiff")


def test_keep_clear_brings_a_point_past_a_border_back_onto_the_road() -> None:
    """A resampling's chord can cut across a sharp border tip (penbay_pro_cw's): keep_clear moves such a
    point back onto the road, where a distance alone (blind to the side) pushed it further off."""
    _, inner, outer = ring(1.0, 0.6)  # the road runs from radius 0.7 to 1.3
    borders = (border_polyline(inner, True), border_polyline(outer, True))
    pts = np.array([[0.68, 0.01], [0.72, 0.01], [1.0, 0.01], [1.28, 0.01], [1.32, 0.01]])
    assert inside_road(pts, borders, True).tolist() == [False, True, True, True, False]
    radii = np.linalg.norm(keep_clear(pts, borders, 0.05, True), axis=1)
    assert radii == pytest.approx([0.75, 0.75, 1.0, 1.25, 1.25], abs=1e-3)
    # an open track's line begins and ends on its start and finish lines, which are not borders
    left, right = np.array([[0.0, 0.5], [5.0, 0.5]]), np.array([[0.0, -0.5], [5.0, -0.5]])
    ends = np.array([[0.0, 0.0], [5.0, 0.0]])
    assert inside_road(ends, (left, right), False).all()
    assert keep_clear(ends, (left, right), 0.05, False) == pytest.approx(ends)


def test_best_lap_refuses_a_car_that_cannot_steer_round_any_line() -> None:
    """Not even the line that spreads the ring's bend over the road bends gently enough for 2 degrees."""
    center, inner, outer = ring(0.5, 0.4)
    stiff = Vehicle(name="stiff", actions=(Action(-2.0, 1.0), Action(2.0, 1.0)))
    with pytest.raises(DrxError, match="needs about .* degrees of steering and the car steers at most 2"):
        best_lap(Track("ring", center, inner, outer), stiff, drive=False)


def test_an_evaluation_races_without_a_best_lap() -> None:
    """The best lap is only a reference beside an evaluation's result: where there is none, ``prepare``
    says why instead of refusing the race (DeepRacer races any car on any track)."""
    from drx.evaluate.service import _best_lap

    center, inner, outer = ring(0.5, 0.4)
    stiff = Vehicle(name="stiff", actions=(Action(-2.0, 1.0), Action(2.0, 1.0)))
    best, why = _best_lap(Track("ring", center, inner, outer), stiff, "ring", "stiff")
    assert best is None and "steers at most 2" in why
    best, why = _best_lap(Track("ring", center, inner, outer), FAST, "ring", "fast")
    assert best is not None and why == ""


def _shared(name: str) -> Track:
    path = SHARED / f"{name}.npy"
    if not path.is_file():
        pytest.skip(f"{path} is absent: the real DeepRacer tracks live in ../shared/tracks beside the repo")
    track, _ = Track.from_route(np.load(path), name)
    return track


# Twelve routes with the quirks worth a test (../shared/tracks/README.md's table: direction, repeated
# points, borders not perpendicular, an open track, the long Spain track), solved in CI; the best lap
# of all 129 shipped routes takes 5-15 minutes on 2 cores, so that walk is a slow test.
CI_NAMES = [
    "2022_june_pro", "2022_reinvent_champ", "Bowtie_track", "Canada_Training", "China_eval_track",
    "FS_June2020", "Oval_track", "Spain_track", "Straight_track", "reInvent2019_track",
    "reInvent2019_wide_cw", "reinvent_base",
]  # fmt: skip
OTHER_NAMES = sorted({p.stem for p in SHARED.glob("*.npy")} - set(CI_NAMES))


@pytest.mark.parametrize(
    "name", [*CI_NAMES, *(pytest.param(name, marks=pytest.mark.slow) for name in OTHER_NAMES)]
)
def test_line_stays_inside_the_borders_on_every_real_track(name: str) -> None:
    """The best lap's line keeps the car's centre :data:`LAP_LINE_CLEARANCE` inside the borders (DeepRacer's
    car is off track only when no wheel is on the road: the outer wheels may leave it) and on the road;
    the reward functions' line (``params["racing_line"]``) keeps every wheel on the road."""
    track = _shared(name)
    best = best_lap(track, FAST)
    pts = best.line.points
    for border in (track.inner, track.outer):
        assert np.min(distance_to_polyline(pts, border)) >= LAP_LINE_CLEARANCE - 1e-6
    assert track.on_road(pts).all()
    waypoints = np.array(racing_line_waypoints(track))
    for border in (track.inner, track.outer):
        # the points the resampling's chords pushed towards a border (by up to 1.6 cm) are moved back out
        assert np.min(distance_to_polyline(waypoints, border)) >= HALF_WIDTH - 1e-6
    assert track.on_road(waypoints).all()
    # a racing line is never longer than the centre line, and the lap beats the top speed's bound
    assert best.line.length <= track.length + 1e-6
    assert best.lap_time >= best.line.length / 4.0
    # the profile's lap from rest is no faster than its flying lap (the driven lap is timed by DeepRacer's
    # rules, from the reference point 0.14 m ahead of the start: on Straight_track it beats both)
    assert best.estimate_time >= best.flying_lap_time


def test_racing_line_params_key_matches_the_waypoints() -> None:
    track = _shared("reinvent_base")
    line = racing_line_waypoints(track)
    assert len(line) == len(track.waypoints)
    assert line[0] == line[-1]
    assert all(isinstance(x, float) and isinstance(y, float) for x, y in line)


def test_best_lap_png(tmp_path: Path) -> None:
    track = _shared("reinvent_base")
    out = draw_best_lap(track, best_lap(track, FAST), tmp_path / "best.png")
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_reward_function_sees_the_racing_line_in_params() -> None:
    from drx.evaluate.theoretical_lap import PARAMS_KEY
    from drx.sim.env import DeepRacerEnv
    from drx.sim.track import load_track

    track = load_track("oval")
    seen: list[int] = []

    def reward(params: dict) -> float:
        line = params[PARAMS_KEY]
        seen.append(len(line))
        x, y = line[params["closest_waypoints"][1]]
        return 1.0 / (1.0 + math.hypot(params["x"] - x, params["y"] - y))

    env = DeepRacerEnv(
        track=track, reward_function=reward, extra_params={PARAMS_KEY: racing_line_waypoints(track)}
    )
    env.reset(options={"start": 0.0})
    _, r, *_ = env.step(0)
    assert seen == [len(track.waypoints)] and 0 < r <= 1


def test_a_top_speed_bound_car_takes_a_shorter_line() -> None:
    """At 1 m/s grip never binds: the best lap drives a blend towards the shortest path, still steerable."""
    from drx.evaluate.theoretical_lap import cached_racing_line
    from drx.sim.track import load_track
    from drx.vehicle import default_vehicle

    track = load_track("oval")
    car = default_vehicle()
    best = best_lap(track, car)
    curvy = best_lap_on_line(cached_racing_line(track, LAP_LINE_CLEARANCE), car_limits(car))
    assert best.line.length_weight > 0 and best.line.length < curvy.line.length
    assert best.lap_time < curvy.lap_time
    assert np.max(np.abs(best.line.curvature)) <= car_limits(car).tightest_curvature
    assert best.line.clearance >= LAP_LINE_CLEARANCE - 1e-6
    # the fast car keeps the minimum-curvature line
    assert best_lap(track, FAST).line.length_weight == 0


def test_speed_colours_span_the_cars_own_speeds_once_under_way() -> None:
    """Issue 14: the colour bar must not span 0-4 m/s for a 1 m/s car, nor let the start from
    rest squeeze the whole lap into one colour."""
    from drx.evaluate.theoretical_lap_plot import _colour_range

    from_rest = np.array([0.0, 0.3, 0.7, 0.95, 0.98, 0.9, 0.62, 0.75, 0.98, 0.97])
    lo, hi = _colour_range(from_rest)
    assert (lo, hi) == (pytest.approx(0.62), pytest.approx(0.98))  # the braking point, the top speed
    flat = np.array([0.0, 0.5, 1.0, 1.0, 1.0])
    lo, hi = _colour_range(flat)
    assert hi == pytest.approx(1.0) and 0.9 <= lo <= 0.95 + 1e-9  # never a zero-width bar


def test_a_scripted_driver_on_the_racing_line_laps_near_the_best_lap() -> None:
    """Pure pursuit that steers from where the car will be once its command acts laps within 5 % of
    the bound on reInvent2019 without leaving the road (benchmarks/best_lap.py's driver; issue 25's
    criterion, issue 10's was 10 %); steering from
    where the car is loses time to the car's delay and yaw lag. At full throttle wherever the profile
    accelerates, the driver beats the bound here by about 3 %: it corners faster than the solver's
    steady full-lock turn (the bound is an estimate). ``best_lap``'s driven lap is the fastest of the
    driver's settings, so no slower than any one of them."""
    from drx.evaluate.driven_lap import LOOKAHEAD, LOOKAHEAD_TIMES
    from drx.evaluate.scripted import PathFollower
    from drx.evaluate.time_trial import RaceRules, max_steps_for, run_time_trial
    from drx.sim.env import DeepRacerEnv

    path = SHARED / "reInvent2019_track.npy"
    if not path.exists():
        pytest.skip(f"{path} is absent: DeepRacer's tracks live in ../shared/tracks beside the repo")
    track, _ = Track.from_route(np.load(path), path.stem)
    best = best_lap(track, FAST)
    rules = RaceRules(laps=1, time_cap_minutes=2.0)
    laps = {}
    for anticipate in (True, False):
        env = DeepRacerEnv(track=track, vehicle=FAST, mode="evaluation", max_steps=max_steps_for(rules),
                           deterministic=True)  # fmt: skip
        clean = [math.inf]
        for lookahead_time in LOOKAHEAD_TIMES:  # the line runs along the borders: the settings that stay on
            driver = PathFollower(env, best.line.points, best.speeds, closed=True, lookahead=LOOKAHEAD,
                                  lookahead_time=lookahead_time, anticipate=anticipate)  # fmt: skip
            trial = run_time_trial(env, driver, rules).complete_laps
            clean += [lap.time for lap in trial if lap.time is not None and not lap.off_track_count]
        laps[anticipate] = min(clean)
    assert abs(laps[True] / best.estimate_time - 1.0) < 0.05
    assert best.driven_time is not None and best.driven_time <= laps[True]
    assert best.lap_time == min(best.estimate_time, best.driven_time)
    assert laps[True] < laps[False]


def test_the_best_lap_is_the_faster_of_the_profile_and_a_driven_lap() -> None:
    """``best_lap`` drives its line in the simulator (:mod:`drx.evaluate.driven_lap`) and keeps the faster
    lap; ``drive=False`` keeps the speed profile's."""
    center, inner, outer = ring(2.0, 1.0)
    track = Track("ring", center, inner, outer)
    best = best_lap(track, FAST)
    assert best.driven_time is not None and best.driven_time > 0
    assert best.lap_time == min(best.estimate_time, best.driven_time)
    profile_only = best_lap(track, FAST, drive=False)
    assert profile_only.driven_time is None
    assert profile_only.lap_time == profile_only.estimate_time == pytest.approx(best.estimate_time)
    slow = best_lap(track, FAST, speed_scales=(0.5,))  # a driver told to take it easy laps slower
    assert slow.driven_time is not None and best.driven_time < slow.driven_time
    assert slow.estimate_time == best.estimate_time
    d = best.to_dict()
    assert d["lap_time"] == round(best.lap_time, 3)
    assert d["driven_lap_time"] == round(best.driven_time, 3)
    assert d["estimate_lap_time"] == round(best.estimate_time, 3)


def test_a_driver_that_leaves_the_road_drives_no_lap() -> None:
    """Asked for 4 m/s round a 1 m ring by a car whose grip does not fall with wheel slip (so the driver
    does not hold its throttle back in the bend), the scripted driver slides off: no lap to count."""
    from drx.evaluate.driven_lap import driven_lap

    center, inner, outer = ring(1.0, 0.5)
    track = Track("tight", center, inner, outer)
    no_slip = CarParams().with_values(grip_slip=0.0)
    assert driven_lap(track, FAST, center, np.full(len(center), 4.0), no_slip) is None
    line = best_lap(track, FAST, drive=False)
    assert driven_lap(track, FAST, line.line.points, line.speeds) is not None


def test_braking_into_a_bend_is_gentler_than_on_a_straight() -> None:
    """The profile brakes in a bend only as hard as the grip the bend needs allows (the simulator's
    wheels slip backwards under a low command), so a lap with a bend costs at least as much as before."""
    limits = car_limits(FAST)
    assert limits.brake_in_bend(3.0, 0.0) == limits.brake(3.0)
    assert limits.brake_in_bend(3.0, 0.3) < limits.brake(3.0)  # 2.7 m/s^2 of 3.6: little slip to spare
    assert limits.brake_in_bend(3.0, 0.45) == 0.0  # 4 m/s^2: beyond grip, no braking slip at all
    free = car_limits(FAST, CarParams().with_values(grip_slip=0.0))
    assert free.brake_in_bend(3.0, 0.3) == free.brake(3.0)


def test_a_hairpin_line_is_spread_over_the_road_and_laps_faster() -> None:
    """On 2022_reinvent_champ the minimum-curvature line gathers each hairpin into points tighter than
    the car turns at 1.5 m/s; with its curvature capped there (reweighted solves) the sharpest bend
    stays within the cap, the line stays on the road and the lap is faster, and best_lap takes it."""
    from drx.evaluate.theoretical_lap import HAIRPIN_SPEEDS, cached_racing_line

    track = _shared("2022_reinvent_champ")
    limits = car_limits(FAST)
    cap = float(limits.turning_curvature(np.array([HAIRPIN_SPEEDS[0]]))[0])
    plain = cached_racing_line(track, LAP_LINE_CLEARANCE)
    capped = cached_racing_line(track, LAP_LINE_CLEARANCE, max_curvature=cap)
    assert np.max(np.abs(plain.curvature)) > 1.5 * cap
    assert np.max(np.abs(capped.curvature)) <= 1.1 * cap
    assert track.on_road(capped.points).all()
    faster = best_lap_on_line(capped, limits).estimate_time
    assert faster < 0.95 * best_lap_on_line(plain, limits).estimate_time
    assert best_lap(track, FAST, drive=False).estimate_time == pytest.approx(faster)


@pytest.mark.slow  # 12-50 s: a whole best lap of hamption_open
def test_a_hairpin_round_a_sharp_border_tip_is_driven_on_a_spread_line() -> None:
    """hamption_open's hairpin wraps round the sharp tip of its inner border (0.08 m radius at the centre
    line): the minimum-curvature line turns there in one or two points, tighter than 30 degrees of lock
    steer even an ideal bicycle. That line is not the lap: best_lap drives the line that spreads the
    hairpin over the road (a bend the car turns at 1.5 m/s), instead of refusing the track."""
    from drx.evaluate.theoretical_lap import cached_racing_line

    track = _shared("hamption_open")
    limits = car_limits(FAST)
    assert np.max(np.abs(cached_racing_line(track, LAP_LINE_CLEARANCE).curvature)) > limits.max_curvature
    best = best_lap(track, FAST, drive=False)
    assert np.max(np.abs(best.line.curvature)) <= 1.1 * float(limits.turning_curvature(np.array([1.5]))[0])
    assert best.line.clearance >= LAP_LINE_CLEARANCE - 1e-6 and track.on_road(best.line.points).all()
    assert best.lap_time < best.line.length / 2.0  # at race pace, not at a crawl round the hairpin
