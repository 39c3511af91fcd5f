"""Stay inside the two borders.

The car earns a full reward whenever all four wheels are on the road and it
keeps a small margin to the border, and almost nothing otherwise. It is free
to use the whole road, so it tends to find its own line; it learns to stay on
the track without caring where on the road it is.
"""

MARGIN = 0.05  # [m] distance to keep from the border


def reward_function(params: dict) -> float:
    """Reward 1.0 when on the road with a margin to the border, else 0.001."""
    all_wheels_on_track = params["all_wheels_on_track"]
    distance_from_center = params["distance_from_center"]
    track_width = params["track_width"]

    reward = 1e-3
    if all_wheels_on_track and (0.5 * track_width - distance_from_center) >= MARGIN:
        reward = 1.0

    return float(reward)
