"""``drx model create NAME --track T --recipe race-pace``: the recipe's choices, overrides and bad input."""

from __future__ import annotations

import pytest

from drx.recipes.race_pace import DEFAULT_ACTIONS, HYPERPARAMETERS, RECIPE_KIND, STOP_CONDITIONS

from .helpers import fails_unchanged, ok, ok_json

TRACK = "reInvent2019_wide_cw"


def _choices(model: dict) -> dict[str, dict]:
    return {c["setting"]: c for c in model["recipe"]["choices"]}


def test_the_recipe_builds_the_car_reward_algorithm_and_settings_and_says_why() -> None:
    made = ok_json("model", "create", "fast", "--track", TRACK, "--recipe", "race-pace")
    assert made["recipe"]["name"] == "race-pace" and made["recipe"]["kind"] == RECIPE_KIND
    space = made["vehicle"]["action_space"]  # race-pace: a box round the line's commands
    assert made["vehicle"]["action_space_type"] == "continuous" and space["speed"]["high"] == 4.0
    assert space["steering_angle"]["low"] < 0.0 < space["steering_angle"]["high"] <= 30.0
    assert made["reward_file"] == f"race_pace_{TRACK}.py" and made["algorithm"] == "ppo"
    for key, value in HYPERPARAMETERS.items():
        assert made["hyperparameters"][key] == value, key
    assert made["stop_conditions"]["max_minutes"] == STOP_CONDITIONS["max_minutes"]
    choices = _choices(made)
    assert {"car", "action space", "reward", "algorithm", "stop conditions", *HYPERPARAMETERS} <= set(choices)
    assert all(c["why"] and not c["overridden"] for c in choices.values())
    shown = ok("model", "show", "fast").stdout
    assert "Recipe race-pace" in shown and "learning rate schedule" in shown
    code = ok_json("reward", "show", "fast")["code"]
    assert "RACING_LINE = [" in code and "def reward_function(params):" in code


def test_every_choice_can_be_overridden_and_says_so() -> None:
    ok("garage", "add", "box", "--continuous", "--max-speed", "3")
    made = ok_json(
        "model", "create", "mine", "--track", TRACK, "--recipe", "race-pace", "--car", "box",
        "--reward", "pursuit", "--lr", "0.0001", "--max-minutes", "12",
    )  # fmt: skip
    assert made["car"] == "box" and made["reward_file"] == "pursuit.py"
    assert made["hyperparameters"]["learning_rate"] == 0.0001
    assert made["hyperparameters"]["batch_size"] == HYPERPARAMETERS["batch_size"]  # the recipe's still
    assert made["stop_conditions"]["max_minutes"] == 12
    choices = _choices(made)
    assert all(choices[k]["overridden"] for k in ("car", "reward", "learning_rate", "stop conditions"))
    assert not choices["batch_size"]["overridden"]
    assert "yours (given as an option)" in ok("model", "show", "mine").stdout


def test_the_discrete_recipe_clusters_the_line_s_commands() -> None:
    made = ok_json("model", "create", "grid", "--track", TRACK, "--recipe", "race-pace-discrete")
    actions = made["vehicle"]["action_space"]
    assert made["vehicle"]["action_space_type"] == "discrete" and len(actions) == DEFAULT_ACTIONS
    assert {"steering_angle": 0.0, "speed": 4.0} in [
        {k: a[k] for k in ("steering_angle", "speed")} for a in actions
    ]


def test_the_continuous_recipe_builds_a_box_round_the_line_that_keeps_straight_ahead() -> None:
    made = ok_json("model", "create", "box", "--track", "oval", "--recipe", "race-pace-continuous",
                   "--algo", "sac")  # fmt: skip
    space = made["vehicle"]["action_space"]
    assert made["vehicle"]["action_space_type"] == "continuous" and made["algorithm"] == "sac"
    assert space["steering_angle"]["low"] <= 0.0 <= space["steering_angle"]["high"]
    assert 0.5 <= space["speed"]["low"] < space["speed"]["high"] <= 4.0
    assert "num_epochs" not in _choices(made)  # PPO's epochs are no choice of a SAC model


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (("--track", TRACK, "--recipe", "fastest"), ("--recipe 'fastest'", "race-pace")),
        (("--track", TRACK, "--track", "oval", "--recipe", "race-pace"), ("--track once",)),
        (
            ("--track", "Straight_track", "--recipe", "race-pace-discrete"),
            ("Straight_track", "race-pace-continuous"),
        ),
        (("--track", "nowhere", "--recipe", "race-pace"), ("nowhere",)),
    ],
)
def test_bad_recipe_input_is_one_sentence_and_stores_nothing(
    args: tuple[str, ...], words: tuple[str, ...]
) -> None:
    fails_unchanged("model", "create", "m", *args, contains=words)


def test_a_car_of_the_other_kind_contradicts_the_recipe() -> None:
    ok("garage", "add", "cont", "--continuous", "--max-speed", "3")
    ok("garage", "add", "grid", "--max-speed", "3")
    create = ("model", "create", "m", "--track", TRACK, "--recipe")
    fails_unchanged(
        *create, "race-pace-discrete", "--car", "cont", contains=("--car cont is continuous", "discrete")
    )
    fails_unchanged(
        *create, "race-pace-continuous", "--car", "grid", contains=("--car grid is discrete", "continuous")
    )


def test_a_track_whose_line_the_car_cannot_steer_is_one_sentence(monkeypatch: pytest.MonkeyPatch) -> None:
    from drx.errors import DrxError
    from drx.recipes import race_pace

    def no_line(*args: object, **kwargs: object) -> None:
        raise DrxError("Car m-car cannot steer the racing line: it bends tighter than 30 degrees.")

    monkeypatch.setattr(race_pace, "line_commands", no_line)
    fails_unchanged("model", "create", "m", "--track", TRACK, "--recipe", "race-pace",
                    contains=("has no racing line the recipe can use", "cannot steer"))  # fmt: skip
