"""Progress and speed: reward getting round the lap quickly.

Each step earns a pace reward, the lap progress made so far per step against
a target pace, plus a speed reward that favours fast actions. Finishing the
lap pays a bonus that grows the fewer steps the lap took. Off the road the
car earns almost nothing. This reward asks for lap time directly, so it
trains best after the car has learned to stay on the road (for example as a
clone of a model trained with follow_center_line.py).
"""

TARGET_STEPS = 300  # steps for a good lap (15 steps per second: a 20 s lap)
MAX_SPEED = 4.0  # [m/s] DeepRacer's fastest action, to scale the speed reward
LAP_BONUS = 10.0  # paid on lap completion, times TARGET_STEPS / steps


def reward_function(params: dict) -> float:
    """Pace (progress per step) + speed, and a bonus for a fast finished lap."""
    if params["is_offtrack"] or not params["all_wheels_on_track"]:
        return 1e-3

    steps = max(1, params["steps"])
    progress = params["progress"]  # percent of the lap, 0..100
    speed = params["speed"]

    target_pace = 100.0 / TARGET_STEPS  # percent per step on a good lap
    pace = progress / steps
    reward_pace = min(pace / target_pace, 2.0)
    reward_speed = (min(speed, MAX_SPEED) / MAX_SPEED) ** 2

    reward = 1e-3 + reward_pace + reward_speed
    if progress >= 100.0:
        reward += LAP_BONUS * min(TARGET_STEPS / steps, 3.0)

    return float(reward)
