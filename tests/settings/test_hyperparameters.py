"""DeepRacer hyperparameters map onto SB3 faithfully."""

from __future__ import annotations

import pytest

from drx.errors import DrxError
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
        ({"batch_size": 100}, "Batch size"),
        ({"num_epochs": 11}, "epochs"),
        ({"learning_rate": 0.1}, "Learning rate"),
        ({"loss_type": "l1"}, "Loss type"),
        ({"episodes_per_iteration": 2}, "Episodes"),
    ],
)
def test_out_of_range(change: dict, message: str) -> None:
    with pytest.raises(DrxError, match=message):
        Hyperparameters().replace(**change)
