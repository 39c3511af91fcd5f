"""How a DeepRacer step stands: the episode-status vocabulary, in DeepRacer's own words.

The values are the words DeepRacer writes in the sim-trace's ``episode_status``
column (deepracer-simapp ``bundle/markov/metrics/constants.py`` ``EpisodeStatus``;
``../shared/DEEPRACER.md`` section 6), so a trace drx writes reads as DeepRacer's.
:class:`EpisodeStatus` is a :class:`~enum.StrEnum`: a member *is* its word (it
compares equal to it, and ``str``, ``format``, ``csv`` and ``json`` give the
word), so stored traces and records are unchanged.

The env (:class:`drx.sim.env.DeepRacerEnv`) is the one place that decides a
step's status; everything else reads it from ``info["episode_status"]`` or the
env's :attr:`~drx.sim.env.DeepRacerEnv.status` (see
``docs/CONTRACTS.md``, Episodes).
"""

from __future__ import annotations

from enum import StrEnum


class EpisodeStatus(StrEnum):
    """A step's episode status (DeepRacer's word as the value)."""

    PREPARE = "prepare"  # the car was just placed (a reset); no step driven yet
    IN_PROGRESS = "in_progress"
    OFF_TRACK = "off_track"  # no wheel on the road (``params["is_offtrack"]``)
    CRASHED = "crashed"  # the car hit a box or a bot car
    REVERSED = "reversed"  # progress went down 15 steps in a row
    IMMOBILIZED = "immobilized"  # moved less than 0.3 mm 15 steps in a row
    LAP_COMPLETE = "lap_complete"
    TIME_UP = "time_up"  # the step limit truncated the episode
    PAUSE = "pause"  # an evaluation's penalty: the car stands before it goes on
    PARK = "park"  # DeepRacer's parked car after a race; drx writes no such row
    REWARD_ERROR = "reward_error"  # drx only: the reward function failed on this step

    @property
    def ends_episode(self) -> bool:
        """Whether a step with this status ends the episode (``terminated`` or ``truncated``)."""
        return self in _ENDINGS

    @property
    def truncates(self) -> bool:
        """Whether this status ends the episode by the step limit rather than by the car (``truncated``)."""
        return self is EpisodeStatus.TIME_UP


# The statuses a step can end an episode with; PREPARE, IN_PROGRESS, PAUSE and PARK do not.
_ENDINGS = frozenset(
    {
        EpisodeStatus.OFF_TRACK,
        EpisodeStatus.CRASHED,
        EpisodeStatus.REVERSED,
        EpisodeStatus.IMMOBILIZED,
        EpisodeStatus.LAP_COMPLETE,
        EpisodeStatus.TIME_UP,
        EpisodeStatus.REWARD_ERROR,
    }
)
