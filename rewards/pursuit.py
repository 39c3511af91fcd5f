"""The "pursuit" reward: progress per step (pace) plus the speed squared, on the road only.

A reward from a published re-run of DeepRacer training (the experiments of issue 23 and
``benchmarks/race_pace.py``): ``progress / steps`` grows with the lap's pace, ``speed ** 2``
pays the fast actions, and a car with a wheel off the road earns almost nothing.
"""


def reward_function(params):
    if params["all_wheels_on_track"] and params["steps"] > 0:
        reward = ((params["progress"] / params["steps"]) * 100) + (params["speed"] ** 2)
    else:
        reward = 0.01
    return float(reward)
