"""DeepRacer hyperparameters map onto SB3 faithfully."""

from __future__ import annotations

import pytest

from drx.errors import DrxError, SettingError
from drx.settings.hyperparameters import Hyperparameters


def test_deepracer_json_round_trip() -> None:
    hp = Hyperparameters.from_dict(
        {"batch_size": 128, "num_epochs": 5, "lr": 1e-4, "beta_entropy": 0.02, "discount_factor": 0.95,
         "loss_type": "mean squared error", "num_episodes_between_training": 10, "network": "compact"}
    )  # fmt: skip
    assert (hp.batch_size, hp.num_epochs, hp.learning_rate, hp.entropy) == (128, 5, 1e-4, 0.02)
    assert (hp.discount_factor, hp.loss_type, hp.episodes_per_iteration) == (0.95, "mse", 10)
    js = hp.to_deepracer_json()
    assert (
        js["loss_type"] == "mean squared error"
        and js["lr"] == 1e-4
        and js["num_episodes_between_training"] == 10
    )
    assert Hyperparameters.from_dict(js) == hp


def test_ppo_and_sac_kwargs() -> None:
    ppo = Hyperparameters().ppo_kwargs()
    assert ppo["clip_range"] == 0.2 and ppo["gae_lambda"] == 0.95 and ppo["batch_size"] == 64
    assert ppo["n_epochs"] == 10 and ppo["ent_coef"] == 0.01 and ppo["learning_rate"] == 3e-4
    assert Hyperparameters().optimizer_kwargs() == {"eps": 1e-5, "fused": True}
    sac = Hyperparameters.default("sac")
    assert sac.loss_type == "mse" and sac.episodes_per_iteration == 1
    assert sac.sac_kwargs()["ent_coef"] == 0.2


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"batch_size": 100}, "^batch_size 100 is not allowed; use one of 32, 64, 128, 256, 512"),
        ({"num_epochs": 11}, "^num_epochs 11 is out of range; use 3 to 10"),
        ({"learning_rate": 0.1}, "^learning_rate 0.1 is out of range; use 1e-8 to 1e-3"),
        ({"loss_type": "l1"}, "^loss_type 'l1' is unknown; use huber or mse"),
        ({"episodes_per_iteration": 2}, "^episodes_per_iteration 2 is out of range; use 5 to 100"),
    ],
)
def test_out_of_range(change: dict, message: str) -> None:
    with pytest.raises(DrxError, match=message):
        Hyperparameters().replace(**change)


def test_deepracer_defaults_as_stored() -> None:
    ppo = Hyperparameters.build("ppo", {}).to_model_json("shallow")
    assert (ppo["batch_size"], ppo["num_epochs"], ppo["learning_rate"], ppo["entropy"]) == (
        64,
        10,
        3e-4,
        0.01,
    )
    assert (ppo["discount_factor"], ppo["loss_type"], ppo["episodes_per_iteration"]) == (0.99, "huber", 20)
    assert ppo["network"] == "shallow"
    sac = Hyperparameters.build("sac", {}).to_model_json("deep")
    assert (sac["loss_type"], sac["episodes_per_iteration"], sac["sac_alpha"]) == ("mse", 1, 0.2)


def test_learning_rate_schedule_is_anneal_unless_asked() -> None:
    """drx's anneal by default, for PPO and SAC and for a DeepRacer hyperparameters.json without the
    setting; its SB3 rate is the constant one (the trainer multiplies it, drx.train.anneal), as
    DeepRacer's ``constant``'s is."""
    for algorithm in ("ppo", "sac"):
        hp = Hyperparameters.default(algorithm)
        assert hp.lr_schedule == "anneal" and hp.learning_rate_schedule() == 3e-4
        assert Hyperparameters.build(algorithm, {}).lr_schedule == "anneal"
    deepracer = Hyperparameters.from_dict({"algorithm": "ppo", "lr": 1e-4})
    assert deepracer.lr_schedule == "anneal" and deepracer.learning_rate_schedule() == 1e-4
    stored = Hyperparameters.from_dict({"algorithm": "ppo", "learning_rate": 1e-4, "lr_schedule": "constant"})
    assert stored.lr_schedule == "constant" and stored.learning_rate_schedule() == 1e-4
    assert Hyperparameters.build("sac", {"lr_schedule": "anneal"}).lr_schedule == "anneal"
    assert Hyperparameters.build("ppo", {"lr_schedule": "constant"}).lr_schedule == "constant"
    linear = Hyperparameters.build("sac", {"lr_schedule": "linear", "learning_rate": 1e-4})
    schedule = linear.learning_rate_schedule()
    assert callable(schedule)
    assert (schedule(1.0), schedule(0.25), schedule(0.0)) == pytest.approx((1e-4, 2.5e-5, 0))
    assert "lr_schedule" not in linear.to_deepracer_json()  # not a DeepRacer setting
    settle = linear.replace(lr_schedule="settle").learning_rate_schedule()
    assert callable(settle)  # full for the first half of the run, then down to zero
    assert [settle(r) for r in (1.0, 0.5, 0.25, 0.0)] == pytest.approx([1e-4, 1e-4, 5e-5, 0])


def test_build_from_overrides_and_base() -> None:
    hp = Hyperparameters.build(
        "ppo", {"learning_rate": 1e-4, "batch_size": 128, "loss_type": "mse", "lr": None}
    )
    assert (hp.learning_rate, hp.batch_size, hp.loss_type) == (1e-4, 128, "mse")
    clone = Hyperparameters.build("ppo", {"num_epochs": 3, "entropy": None}, base=hp.to_model_json("shallow"))
    assert (clone.learning_rate, clone.num_epochs, clone.entropy) == (1e-4, 3, 0.01)


@pytest.mark.parametrize(
    ("algo", "overrides", "sentence"),
    [
        ("ppo", {"batch_size": 100}, "batch_size 100 is not allowed; use one of 32, 64, 128, 256, 512."),
        ("ppo", {"entropy": 1.5}, "entropy 1.5 is out of range; use 0 to 1."),
        ("ppo", {"discount_factor": -0.1}, "discount_factor -0.1 is out of range; use 0 to 1."),
        ("sac", {"episodes_per_iteration": 101}, "episodes_per_iteration 101 is out of range; use 1 to 100."),
        ("sac", {"sac_alpha": 2.0}, "sac_alpha 2 is out of range; use 0 to 1."),
        ("ppo", {"loss_type": "l1"}, "loss_type l1 is unknown; use huber or mse."),
        (
            "sac",
            {"lr_schedule": "cosine"},
            "lr_schedule cosine is unknown; use anneal, constant, linear or settle.",
        ),
        ("ppo", {"sac_alpha": 0.3}, "sac_alpha does not apply to PPO; use it with algorithm sac."),
        ("sac", {"num_epochs": 5}, "num_epochs does not apply to SAC; use it with algorithm ppo."),
        ("sac", {"entropy": 0.1}, "entropy does not apply to SAC; use it with algorithm ppo."),
    ],
)
def test_errors_name_the_field_value_and_allowed_values(algo: str, overrides: dict, sentence: str) -> None:
    with pytest.raises(SettingError) as info:
        Hyperparameters.build(algo, overrides)
    assert str(info.value) == sentence
    assert info.value.field == next(iter(overrides))
    assert "--" not in str(info.value)
