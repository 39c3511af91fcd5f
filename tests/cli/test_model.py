"""``drx model create|clone|list|show|lineage|rm``."""

from __future__ import annotations

from pathlib import Path

import pytest

from .helpers import fails_unchanged, ok, ok_json, write


def test_create_with_defaults_and_show() -> None:
    m = ok_json("model", "create", "first")
    assert (m["car"], m["track"], m["reward_file"], m["algorithm"], m["status"]) == (
        "default", "oval", "follow_center_line.py", "ppo", "draft"
    )  # fmt: skip
    assert m["hyperparameters"]["batch_size"] == 64 and m["stop_conditions"]["max_minutes"] == 60
    assert len(m["reward_sha256"]) == 64 and m["vehicle"]["action_space_type"] == "discrete"
    shown = ok_json("model", "show", "first")
    assert shown["name"] == "first" and shown["clones"] == [] and shown["jobs"] == 0
    out = ok("model", "show", "first").stdout
    assert "learning rate" in out and "60 min" in out
    assert [x["name"] for x in ok_json("model", "list")] == ["first"]
    assert "first" in ok("model", "list").stdout


def test_create_with_every_option(tmp_path: Path) -> None:
    reward = write(tmp_path / "mine.py", "def reward_function(params):\n    return 1.0\n")
    ok("garage", "add", "fast", "--max-speed", "3")
    m = ok_json("model", "create", "all-options", "--car", "fast", "--track", "kidney", "--reward", reward,
                "--batch-size", "128", "--epochs", "5", "--lr", "0.0001", "--entropy", "0.02",
                "--discount", "0.95", "--loss", "mse", "--episodes-per-iteration", "10",
                "--max-minutes", "5", "--max-steps", "10000", "--max-episodes", "300",
                "--target-iterations", "3", "--network", "deep", "--description", "everything")  # fmt: skip
    hp = m["hyperparameters"]
    assert (hp["batch_size"], hp["num_epochs"], hp["learning_rate"], hp["entropy"]) == (128, 5, 1e-4, 0.02)
    assert (hp["discount_factor"], hp["loss_type"], hp["episodes_per_iteration"]) == (0.95, "mse", 10)
    assert hp["network"] == "deep" and m["vehicle"]["neural_network"] == "DEEP_CONVOLUTIONAL_NETWORK"
    assert m["stop_conditions"] == {
        "max_minutes": 5,
        "max_steps": 10000,
        "max_episodes": 300,
        "target_iterations": 3,
    }
    assert (m["car"], m["track"], m["reward_file"], m["description"]) == (
        "fast",
        "kidney",
        "mine.py",
        "everything",
    )


def test_sac_on_a_continuous_car() -> None:
    ok("garage", "add", "smooth", "--continuous")
    m = ok_json("model", "create", "soft", "--car", "smooth", "--algo", "sac", "--sac-alpha", "0.5")
    assert m["algorithm"] == "sac" and m["hyperparameters"]["sac_alpha"] == 0.5
    assert m["vehicle"]["training_algorithm"] == "sac"
    assert "SAC alpha" in ok("model", "show", "soft").stdout


def test_a_linear_learning_rate_schedule_is_kept_and_cloned() -> None:
    ok("garage", "add", "smooth", "--continuous")
    m = ok_json("model", "create", "settles", "--car", "smooth", "--lr-schedule", "linear")
    assert m["hyperparameters"]["lr_schedule"] == "linear"
    assert "learning rate schedule" in ok("model", "show", "settles").stdout
    assert ok_json("model", "clone", "settles", "settled")["hyperparameters"]["lr_schedule"] == "linear"


def test_towers_are_kept_split_on_clone_and_never_merged() -> None:
    m = ok_json("model", "create", "shared-trunk")
    assert m["hyperparameters"]["towers"] == "shared"
    split = ok_json("model", "clone", "shared-trunk", "split", "--towers", "separate")
    assert split["hyperparameters"]["towers"] == "separate"
    assert ok_json("model", "clone", "split", "split-2")["hyperparameters"]["towers"] == "separate"
    fails_unchanged(
        "model", "clone", "split", "merged", "--towers", "shared", contains=("--towers", "separate")
    )  # fmt: skip
    fails_unchanged("model", "create", "bad", "--towers", "three", contains="--towers three is unknown")


def test_same_reward_code_is_stored_once(tmp_path: Path) -> None:
    a = write(tmp_path / "a.py", "def reward_function(params):\n    return 1.0\n")
    b = write(tmp_path / "b.py", "def reward_function(params):\n    return 1.0\n")
    ok("model", "create", "a", "--reward", str(a))
    ok("model", "create", "b", "--reward", str(b))
    assert ok_json("info")["counts"]["reward_sources"] == 1
    a.write_text("def reward_function(params):\n    return 2.0\n")  # editing the file changes no model
    assert ok_json("model", "show", "a")["reward_sha256"] == ok_json("model", "show", "b")["reward_sha256"]


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (("ok-name", "--lr", "0.1"), ("0.1", "1e-8 to 1e-3")),
        (("ok-name", "--batch-size", "100"), ("100", "32, 64, 128, 256, 512")),
        (("ok-name", "--epochs", "2"), ("2", "3 to 10")),
        (("ok-name", "--entropy", "1.5"), ("1.5", "0 to 1")),
        (("ok-name", "--discount", "1.1"), ("1.1", "0 to 1")),
        (("ok-name", "--loss", "l1"), ("l1", "huber or mse")),
        (
            ("ok-name", "--lr-schedule", "cosine"),
            ("--lr-schedule cosine", "anneal, constant, linear or settle"),
        ),
        (("ok-name", "--episodes-per-iteration", "200"), ("200", "5 to 100")),
        (("ok-name", "--sac-alpha", "0.5"), ("--sac-alpha", "sac")),
        (("ok-name", "--max-minutes", "0"), ("0", "1 to 1440")),
        (("ok-name", "--max-minutes", "2000"), ("2000", "1 to 1440")),
        (("ok-name", "--max-steps", "0"), ("--max-steps 0",)),
        (("ok-name", "--max-episodes", "0"), ("--max-episodes 0",)),
        (("ok-name", "--target-iterations", "0"), ("--target-iterations 0",)),
        (("ok-name", "--algo", "dqn"), ("dqn", "ppo or sac")),
        (("ok-name", "--algo", "sac"), ("sac", "continuous")),
        (("ok-name", "--network", "resnet"), ("resnet",)),
        (("ok-name", "--car", "ghost"), ("ghost", "default")),
        (("ok-name", "--track", "atlantis"), ("atlantis", "`drx track list`")),
        (("ok-name", "--reward", "nothing.py"), ("nothing.py", "follow_center_line")),
        (("bad.name",), ("bad.name", "letters, digits, '-' and '_'")),
        (("_lead",), ("_lead", "starting with a letter or digit")),
        (("x" * 65,), ("64",)),
    ],
)
def test_bad_create_exits_2_and_changes_nothing(args: tuple[str, ...], words: tuple[str, ...]) -> None:
    fails_unchanged("model", "create", *args, contains=words)


def test_create_refuses_duplicates_and_broken_rewards(tmp_path: Path) -> None:
    ok("model", "create", "taken")
    fails_unchanged("model", "create", "taken", contains=("taken", "already exists"))
    broken = write(tmp_path / "broken.py", "def reward_function(params)\n    return 1.0\n")
    fails_unchanged("model", "create", "new", "--reward", str(broken), contains=("syntax error", "line 1"))


def test_clone_three_generations_and_lineage() -> None:
    ok("model", "create", "gen1", "--lr", "0.0002", "--max-minutes", "5")
    c = ok_json("model", "clone", "gen1", "gen2", "--track", "kidney", "--lr", "0.0001")
    assert (c["parent"], c["track"], c["hyperparameters"]["learning_rate"]) == ("gen1", "kidney", 1e-4)
    assert c["stop_conditions"]["max_minutes"] == 5  # inherited
    g3 = ok_json("model", "clone", "gen2", "gen3", "--reward", "prevent_zigzag", "--max-minutes", "3")
    assert (g3["parent"], g3["track"], g3["reward_file"]) == ("gen2", "kidney", "prevent_zigzag.py")
    assert g3["hyperparameters"]["learning_rate"] == 1e-4
    ok("model", "create", "other")
    tree = ok_json("model", "lineage", "gen3")
    assert len(tree) == 1 and tree[0]["name"] == "gen1"
    assert tree[0]["children"][0]["name"] == "gen2"
    assert tree[0]["children"][0]["children"][0]["name"] == "gen3"
    assert [t["name"] for t in ok_json("model", "lineage")] == ["gen1", "other"]
    out = ok("model", "lineage").stdout
    lines = [line for line in out.splitlines() if "gen" in line]
    assert lines[0].startswith("gen1") and "└── gen2" in lines[1] and "└── gen3" in lines[2]
    assert lines[2].index("gen3") > lines[1].index("gen2")
    assert ok_json("model", "show", "gen2")["clones"] == ["gen3"]


def test_clone_keeps_the_action_space_size() -> None:
    ok("model", "create", "parent")
    ok("garage", "add", "big", "--steering-levels", "7", "--speed-levels", "3")
    fails_unchanged(
        "model", "clone", "parent", "child", "--car", "big", contains=("21 actions", "10 discrete")
    )
    ok("garage", "add", "same-size", "--max-speed", "2")
    assert ok_json("model", "clone", "parent", "child", "--car", "same-size")["car"] == "same-size"


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (("ghost", "new"), ("ghost",)),
        (("parent", "parent"), ("already exists",)),
        (("parent", "bad name"), ("not allowed",)),
        (("parent", "new", "--lr", "5"), ("5", "1e-8 to 1e-3")),
        (("parent", "new", "--sac-alpha", "0.1"), ("--sac-alpha",)),
        (("parent", "new", "--track", "atlantis"), ("atlantis",)),
        (("parent", "new", "--reward", "nothing.py"), ("nothing.py",)),
        (("parent", "new", "--max-minutes", "0"), ("1 to 1440",)),
        (("parent", "new", "--car", "ghost"), ("ghost",)),
    ],
)
def test_bad_clone_exits_2_and_changes_nothing(args: tuple[str, ...], words: tuple[str, ...]) -> None:
    ok("model", "create", "parent")
    fails_unchanged("model", "clone", *args, contains=words)


def test_rm_with_clones_needs_force_and_detaches_them() -> None:
    ok("model", "create", "root")
    ok("model", "clone", "root", "kid")
    ok("model", "clone", "kid", "grandkid")
    fails_unchanged("model", "rm", "kid", contains=("grandkid", "--force"))
    assert ok_json("model", "rm", "kid", "--force") == {"removed": "kid", "detached": ["grandkid"]}
    names = [t["name"] for t in ok_json("model", "lineage")]
    assert names == ["root", "grandkid"]
    assert ok_json("model", "show", "grandkid")["parent"] == "kid"  # kept for the record
    assert "removed" in ok("model", "lineage", "grandkid").stdout
    assert "kid (removed)" in ok("model", "show", "grandkid").stdout
    assert "Removed model grandkid" in ok("model", "rm", "grandkid").stdout
    ok("model", "rm", "root")
    assert ok_json("model", "list") == []
    fails_unchanged("model", "rm", "root", contains="No model named 'root'")
    fails_unchanged("model", "show", "root", contains="root")
    fails_unchanged("model", "lineage", "root", contains="root")
