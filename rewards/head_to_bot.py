"""Head-to-bot: keep a safe gap to the bot car ahead, overtake in the other lane.

Bot cars drive the lanes at their own speed. The car earns:

- a lane reward for staying on the road;
- a gap reward: full when the bot ahead is far away or in the other lane,
  shrinking as the car closes in on it in the same lane;
- an overtaking bonus for being in the other lane while it passes a nearby bot;
- a speed bonus, but only when the lane ahead is clear.

A crash earns almost nothing. With no bots (empty lists) it rewards staying on
the road at speed.
"""

import math

FOLLOW_DISTANCE = 1.5  # [m] closer than this, behind a bot in its lane, costs reward
PASSING_DISTANCE = 1.0  # [m] a bot this close in the other lane is being passed
MAX_SPEED = 4.0  # [m/s] DeepRacer's fastest action, to scale the speed bonus


def reward_function(params: dict) -> float:
    """Lane reward + gap to the bot ahead + overtaking and speed bonuses."""
    if params.get("is_crashed", False) or params.get("is_offtrack", False):
        return 1e-3

    track_width = params["track_width"]
    distance_from_center = params["distance_from_center"]
    all_wheels_on_track = params["all_wheels_on_track"]
    is_left_of_center = params["is_left_of_center"]
    speed = params["speed"]
    objects_location = params.get("objects_location") or []
    objects_left_of_center = params.get("objects_left_of_center") or []
    closest_objects = params.get("closest_objects") or [0, 0]

    reward_lane = 1.0 if all_wheels_on_track and distance_from_center < 0.5 * track_width else 1e-3

    reward_gap = 1.0
    passing = False
    lane_clear = True
    ahead = closest_objects[1]
    if 0 <= ahead < min(len(objects_location), len(objects_left_of_center)):
        bot_x, bot_y = objects_location[ahead]
        gap = math.hypot(params["x"] - bot_x, params["y"] - bot_y)
        if objects_left_of_center[ahead] == is_left_of_center:
            if gap < FOLLOW_DISTANCE:
                lane_clear = False
                reward_gap = max(1e-3, (gap / FOLLOW_DISTANCE) ** 2)
        elif gap < PASSING_DISTANCE:
            passing = True  # in the other lane, right beside the bot

    reward_overtake = 1.0 if passing else 0.0
    reward_speed = min(speed, MAX_SPEED) / MAX_SPEED if lane_clear else 0.0

    reward = 1.0 * reward_lane + 2.0 * reward_gap + 1.0 * reward_overtake + 1.0 * reward_speed
    return float(reward)
