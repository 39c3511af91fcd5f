"""Hyperparameters and stop conditions: DeepRacer's defaults and ranges, drx's stop rules."""

from __future__ import annotations

import pytest

from drx.errors import DrxError
from drx.services.hyperparameters import (
    build_hyperparameters,
    build_stop_conditions,
    describe_stop_conditions,
)


def test_deepracer_defaults() -> None:
    ppo = build_hyperparameters("ppo", "shallow", {})
    assert (ppo["batch_size"], ppo["num_epochs"], ppo["learning_rate"], ppo["entropy"]) == (
        64,
        10,
        3e-4,
        0.01,
    )
    assert (ppo["discount_factor"], ppo["loss_type"], ppo["episodes_per_iteration"]) == (0.99, "huber", 20)
    assert ppo["network"] == "shallow"
    sac = build_hyperparameters("sac", "deep", {})
    assert (sac["loss_type"], sac["episodes_per_iteration"], sac["sac_alpha"]) == ("mse", 1, 0.2)


def test_overrides_and_base() -> None:
    hp = build_hyperparameters(
        "ppo", "shallow", {"learning_rate": 1e-4, "batch_size": 128, "loss_type": "mse"}
    )
    assert (hp["learning_rate"], hp["batch_size"], hp["loss_type"]) == (1e-4, 128, "mse")
    clone = build_hyperparameters("ppo", "shallow", {"num_epochs": 3}, base=hp)
    assert (clone["learning_rate"], clone["num_epochs"]) == (1e-4, 3)


@pytest.mark.parametrize(
    ("algo", "overrides", "words"),
    [
        ("ppo", {"batch_size": 100}, ("100", "32, 64, 128, 256, 512")),
        ("ppo", {"num_epochs": 11}, ("11", "3 to 10")),
        ("ppo", {"learning_rate": 0.01}, ("0.01", "1e-8 to 1e-3")),
        ("ppo", {"entropy": 1.5}, ("1.5", "0 to 1")),
        ("ppo", {"discount_factor": -0.1}, ("-0.1", "0 to 1")),
        ("ppo", {"episodes_per_iteration": 2}, ("2", "5 to 100")),
        ("sac", {"episodes_per_iteration": 101}, ("101", "1 to 100")),
        ("sac", {"sac_alpha": 2.0}, ("2", "0 to 1")),
        ("ppo", {"loss_type": "l1"}, ("l1", "huber or mse")),
        ("ppo", {"sac_alpha": 0.3}, ("--sac-alpha", "sac")),
        ("sac", {"num_epochs": 5}, ("--epochs", "ppo")),
        ("sac", {"entropy": 0.1}, ("--entropy", "ppo")),
    ],
)
def test_out_of_range_values_name_the_value_and_range(algo: str, overrides: dict, words: tuple) -> None:
    with pytest.raises(DrxError) as info:
        build_hyperparameters(algo, "shallow", overrides)
    for word in words:
        assert word in str(info.value)


def test_stop_conditions() -> None:
    stop = build_stop_conditions({})
    assert stop == {"max_minutes": 60, "max_steps": None, "max_episodes": None, "target_iterations": None}
    stop = build_stop_conditions({"max_minutes": 2, "target_iterations": 3, "max_steps": 5000})
    assert describe_stop_conditions(stop) == "2 min, 5000 steps, 3 full-lap iterations in a row"
    assert build_stop_conditions({"max_episodes": 7}, base=stop)["max_minutes"] == 2


@pytest.mark.parametrize(
    ("overrides", "words"),
    [
        ({"max_minutes": 0.5}, ("0.5", "1 to 1440")),
        ({"max_minutes": 1441}, ("1441", "1 to 1440")),
        ({"max_steps": 0}, ("--max-steps 0",)),
        ({"max_episodes": -3}, ("--max-episodes -3",)),
        ({"target_iterations": 0}, ("--target-iterations 0", "1 to 100")),
    ],
)
def test_bad_stop_conditions(overrides: dict, words: tuple) -> None:
    with pytest.raises(DrxError) as info:
        build_stop_conditions(overrides)
    for word in words:
        assert word in str(info.value)
