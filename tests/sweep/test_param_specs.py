"""``--param`` parsing: ranges and choices within DeepRacer's ranges, and one sentence for anything else."""

from __future__ import annotations

import pytest

from drx.errors import DrxError, SettingError
from drx.sweep.param_specs import apply_params, parse_param, parse_params


def test_ranges_and_choices_parse_to_optuna_distributions() -> None:
    lr, batch, epochs, loss, schedule = parse_params(
        ["lr=1e-5:1e-3:log", "batch-size=64,128,256", "epochs=3:10", "loss=huber,MSE",
         "lr-schedule=constant,Linear"], "ppo",
    )  # fmt: skip
    assert (lr.field, lr.low, lr.high, lr.log) == ("learning_rate", 1e-5, 1e-3, True)
    assert lr.distribution().log and lr.distribution().high == 1e-3
    assert batch.choices == (64, 128, 256) and batch.distribution().choices == (64, 128, 256)
    assert epochs.is_int and type(epochs.distribution()).__name__ == "IntDistribution"
    assert loss.choices == ("huber", "mse")
    assert schedule.field == "lr_schedule" and schedule.choices == ("constant", "linear")
    assert [s.text() for s in (lr, batch, epochs)] == [
        "lr=1e-05:0.001:log",
        "batch-size=64,128,256",
        "epochs=3:10",
    ]
    assert parse_param(lr.text(), "ppo") == lr  # the stored text parses back to the same spec
    overrides = apply_params({"lr": 2e-4, "batch-size": 128}, [lr, batch])
    assert overrides == {"learning_rate": 2e-4, "batch_size": 128}


@pytest.mark.parametrize(
    ("text", "algorithm", "words"),
    [
        ("lr=1e-9:1e-3:log", "ppo", ("lr=1e-9:1e-3:log", "outside DeepRacer's range", "1e-8 to 1e-3")),
        ("lr=1e-5:0.01", "ppo", ("outside DeepRacer's range", "0.01")),
        ("batch-size=64,100", "ppo", ("outside DeepRacer's range", "100", "32, 64, 128, 256, 512")),
        ("epochs=2:10", "ppo", ("outside DeepRacer's range", "3 to 10")),
        ("episodes-per-iteration=1:20", "ppo", ("outside DeepRacer's range", "5 to 100")),
        ("discount=0.9:1.5", "ppo", ("outside DeepRacer's range", "0 to 1")),
        ("loss=huber,l1", "ppo", ("outside DeepRacer's range", "l1")),
        ("lr-schedule=constant,cosine", "sac", ("cosine", "anneal, constant, linear or settle")),
        ("lr-schedule=0:1", "ppo", ("list of values", "lr-schedule=anneal,constant,linear,settle")),
        ("lr", "ppo", ("malformed", "NAME=LOW:HIGH")),
        ("lr=", "ppo", ("malformed",)),
        ("lr=1e-5:1e-3:cubic", "ppo", ("malformed",)),
        ("lr=1e-5:1e-3:log:2", "ppo", ("malformed",)),
        ("lr=abc:1e-3", "ppo", ("'abc'", "not a number")),
        ("lr=1e-5:nan", "ppo", ("not a finite number",)),
        ("lr=1e-3:1e-5", "ppo", ("not below HIGH",)),
        ("entropy=0:0.5:log", "ppo", ("log scale", "above 0")),
        ("epochs=3.5:8", "ppo", ("whole numbers",)),
        ("batch-size=32:512", "ppo", ("list of values", "batch-size=32,64,128,256,512")),
        ("learning-rate=1e-5:1e-3", "ppo", ("names no hyperparameter", "batch-size, epochs, lr")),
        ("entropy=0:0.1", "sac", ("does not apply to SAC",)),
        ("sac-alpha=0.1:0.5", "ppo", ("does not apply to PPO",)),
        ("batch-size=64,64", "ppo", ("repeats a value",)),
        ("batch-size=64,,128", "ppo", ("empty value",)),
    ],
)
def test_bad_param_is_one_sentence_naming_it(text: str, algorithm: str, words: tuple[str, ...]) -> None:
    with pytest.raises(DrxError) as info:
        parse_param(text, algorithm)
    message = str(info.value)
    assert "\n" not in message and message.endswith(".")
    for word in words:
        assert word in message, (word, message)


def test_no_param_or_a_repeated_one() -> None:
    with pytest.raises(SettingError, match="at least one param to vary") as info:  # the CLI says --param
        parse_params([], "ppo")
    assert info.value.worded(lambda f: "--" + f).startswith("A sweep needs at least one --param to vary")
    with pytest.raises(DrxError, match="at least one param"):
        parse_params([], "ppo")
    with pytest.raises(DrxError, match="given twice"):
        parse_params(["lr=1e-5:1e-4", "LR=1e-4:1e-3"], "ppo")


def test_sac_ranges_follow_deepracer() -> None:
    (alpha, episodes) = parse_params(["sac-alpha=0.05:0.5", "episodes-per-iteration=1:10"], "sac")
    assert alpha.field == "sac_alpha" and episodes.low == 1
