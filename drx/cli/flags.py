"""The CLI's names for settings: each field a domain error may name, and the flag that sets it.

The domain (settings, services, simulator) raises :class:`~drx.errors.SettingError` naming
fields (``max_minutes``); the CLI's error boundary words the sentence with these flags
(``--max-minutes``), so the user reads the option to change. The one table of flags for fields.
"""

from __future__ import annotations

from drx.errors import DrxError, SettingError

FLAGS: dict[str, str] = {
    # hyperparameters (drx.settings.hyperparameters.Hyperparameters)
    "algorithm": "--algo",
    "batch_size": "--batch-size",
    "num_epochs": "--epochs",
    "learning_rate": "--lr",
    "entropy": "--entropy",
    "discount_factor": "--discount",
    "loss_type": "--loss",
    "episodes_per_iteration": "--episodes-per-iteration",
    "sac_alpha": "--sac-alpha",
    "lr_schedule": "--lr-schedule",
    "towers": "--towers",
    # stop conditions (drx.settings.stop.StopConditions)
    "max_minutes": "--max-minutes",
    "max_steps": "--max-steps",
    "max_episodes": "--max-episodes",
    "target_iterations": "--target-iterations",
    # rollout settings (drx.settings.rollout.RolloutSettings)
    "rollout_workers": "--rollout-workers",
    # the torch device a model trains on (drx.settings.device)
    "device": "--device",
    # the DeepRacer simulator whose car a model trains on (drx.settings.car)
    "simulator": "--simulator",
    # where and which way training episodes start (drx.settings.episodes.EpisodeSettings)
    "alternate_direction": "--alternate-direction",
    "change_start_position": "--change-start-position",
    "round_robin_advance": "--round-robin-advance",
    "start_position_offset": "--start-position-offset",
    # race settings (drx.settings.race.RaceConfig)
    "race_type": "--race-type",
    "objects": "--objects",
    "object_positions": "--object-at",
    "randomize_objects": "--randomize-objects",
    "bots": "--bots",
    "bot_speed": "--bot-speed",
    "bot_lane_change": "--bot-lane-change",
    "randomize_bots": "--randomize-bots",
    "opponents": "--opponent",
    # a car's action space (drx.vehicle.grid_actions)
    "max_steering": "--max-steering",
    "steering_levels": "--steering-levels",
    "max_speed": "--max-speed",
    "speed_levels": "--speed-levels",
    "continuous": "--continuous",
    "min_steering": "--min-steering",
    "min_speed": "--min-speed",
    "sensor": "--sensor",
    "network": "--network",
    "lidar": "--lidar",
    "from_file": "--from",
    "actions_file": "--actions-file",
    "from_racing_line": "--from-racing-line",
    "actions": "--actions",
    # evaluation rules (drx.evaluate.time_trial.RaceRules)
    "laps": "--laps",
    "off_track_penalty": "--off-track-penalty",
    "max_resets": "--max-resets",
    "time_cap_minutes": "--time-cap-minutes",
    "collision_penalty": "--collision-penalty",
    "direction": "--direction",
    "min_laps": "--min-laps",
    # head-to-head rules (drx.evaluate.head_to_head.HeadToHeadRules), DeepRacer's multi-car names
    "reverse_penalty": "--reverse-penalty",
    "immobilized_penalty": "--immobilized-penalty",
    "done_condition": "--done-condition",
    # the leaderboard's choice of rules (drx.evaluate.leaderboard)
    "rules_of": "--rules-of",
    # evaluation, pictures, files and the rest
    "checkpoint": "--checkpoint",
    "seed": "--seed",
    "png": "--png",
    "rank": "--rank",
    "video": "--video",
    "port": "--port",
    "progress": "--progress",
    "heading": "--heading",
    "offset": "--offset",
    "scale": "--scale",
    "iteration": "--iteration",
    "out": "--out",
    "track": "--track",
    "recipe": "--recipe",
    "car": "--car",
    "reward": "--reward",
    "trust_reward": "--trust-reward",
    "force": "--force",
    "track_name": "--name",
    "source": "--source",
    # sweeps (drx.sweep)
    "trials": "--trials",
    "metric": "--metric",
    "pruner": "--pruner",
    "startup_trials": "--startup-trials",
    "warmup_iterations": "--warmup-iterations",
    "max_minutes_per_trial": "--max-minutes-per-trial",
    "param": "--param",
}


def flag(field: str) -> str:
    """The flag that sets ``field`` (the field's own name when no option sets it)."""
    return FLAGS.get(field, field)


def cli_sentence(exc: DrxError) -> str:
    """The sentence the CLI prints for ``exc``: a setting is named by its flag."""
    if isinstance(exc, SettingError):
        return exc.worded(flag)
    return str(exc)
