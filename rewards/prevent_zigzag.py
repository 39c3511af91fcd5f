"""Follow the centre line, without zig-zagging.

The three-band centre-line reward, reduced by 20% whenever the car steers
harder than a threshold. Hard steering on a straight makes the car weave; the
penalty teaches it to steer only as much as the road needs. Lower the
threshold for a calmer car, raise it for tracks with tight corners.
"""

ABS_STEERING_THRESHOLD = 15.0  # [deg] steering above this is penalised
STEERING_PENALTY = 0.8  # multiply the reward by this when steering too hard


def reward_function(params: dict) -> float:
    """Centre-line bands, times 0.8 when |steering| exceeds the threshold."""
    distance_from_center = params["distance_from_center"]
    track_width = params["track_width"]
    abs_steering = abs(params["steering_angle"])  # only the amount matters, not the side

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
        reward = 1e-3

    if abs_steering > ABS_STEERING_THRESHOLD:
        reward *= STEERING_PENALTY

    return float(reward)
