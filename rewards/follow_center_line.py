"""Follow the centre line: the classic DeepRacer starter reward.

Three bands around the centre line, each 10%, 25% and 50% of the road width
wide. The closer the car is to the centre, the higher the reward; beyond the
widest band the car is probably leaving the road and earns almost nothing.
It learns a steady, centred lap quickly, but not a fast racing line.
"""


def reward_function(params: dict) -> float:
    """Reward 1.0 / 0.5 / 0.1 / 0.001 by distance from the centre line."""
    track_width = params["track_width"]
    distance_from_center = params["distance_from_center"]

    # Three markers at increasing distances from the centre line.
    marker_1 = 0.1 * track_width
    marker_2 = 0.25 * track_width
    marker_3 = 0.5 * track_width

    if distance_from_center <= marker_1:
        reward = 1.0
    elif distance_from_center <= marker_2:
        reward = 0.5
    elif distance_from_center <= marker_3:
        reward = 0.1
    else:
        reward = 1e-3  # likely crashed or close to off track

    return float(reward)
