"""Object avoidance: stay on the road and out of the next box's lane.

Two parts, weighted 1 : 4. The lane part is the stay-inside-the-borders
reward. The avoidance part looks at the next object ahead
(``closest_objects[1]``): when the car is in the same lane as the box
(``objects_left_of_center`` against ``is_left_of_center``), the reward drops
the closer the car gets, so the car learns to change lanes before the box.
A crash earns almost nothing. With no objects on the track (empty lists) it
is simply the lane reward plus a full avoidance part.
"""

import math

SAFE_DISTANCE = 0.8  # [m] closer than this, in the box's lane, costs reward


def reward_function(params: dict) -> float:
    """Lane reward + 4 x avoidance reward (1.0 when clear of the next box's lane)."""
    all_wheels_on_track = params["all_wheels_on_track"]
    distance_from_center = params["distance_from_center"]
    track_width = params["track_width"]
    objects_location = params.get("objects_location") or []
    objects_left_of_center = params.get("objects_left_of_center") or []
    closest_objects = params.get("closest_objects") or [0, 0]
    is_left_of_center = params["is_left_of_center"]

    if params.get("is_crashed", False):
        return 1e-3

    # Stay on the road, a little away from the border.
    inside_margin = (0.5 * track_width - distance_from_center) >= 0.05
    reward_lane = 1.0 if all_wheels_on_track and inside_margin else 1e-3

    # Keep out of the lane of the next object ahead.
    reward_avoid = 1.0
    next_index = closest_objects[1]
    if 0 <= next_index < min(len(objects_location), len(objects_left_of_center)):
        box_x, box_y = objects_location[next_index]
        distance = math.hypot(params["x"] - box_x, params["y"] - box_y)
        same_lane = objects_left_of_center[next_index] == is_left_of_center
        if same_lane:
            if distance < 0.3:
                reward_avoid = 1e-3
            elif distance < 0.5:
                reward_avoid = 0.2
            elif distance < SAFE_DISTANCE:
                reward_avoid = 0.5

    reward = 1.0 * reward_lane + 4.0 * reward_avoid
    return float(reward)
